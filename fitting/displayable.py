"""How a FitResult shows itself: a one-line ``repr`` here, the notebook's HTML
(``fitting.result_display``, engine-only) imported only when a notebook asks.

The measured | fitted | difference spheres come from the preview renderer,
which the engine may not import: ``%load_ext brdf_fit.notebook`` (the
application) registers an IPython formatter for FitResult that adds them
(docs/notebooks.md).
"""


class ResultDisplay:
    """Mixin of FitResult: short ``repr`` and ``_repr_html_``."""

    def __repr__(self) -> str:
        errors = self.errors or {}
        parts = [f"{name} {errors[key]:.5g}" for name, key in (("M1", "m1"), ("image", "image"))
                 if isinstance(errors.get(key), (int, float))]
        return f"<FitResult {self.spec} on {self.material!r}" + (": " + ", ".join(parts) if parts else "") + ">"

    def _repr_html_(self) -> str:
        from .result_display import result_html
        return result_html(self)
