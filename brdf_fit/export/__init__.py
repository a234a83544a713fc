"""Material files: glTF (``gltf``, ``gltf_file``) and MaterialX (``materialx_file``),
the honesty check of an export (``honesty``) and export-first (``export_first``)."""
