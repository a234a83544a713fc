"""shaders."""
