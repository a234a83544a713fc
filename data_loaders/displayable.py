"""How a MeasuredBRDF shows itself: a one-line ``repr`` here, the notebook's
HTML and PNG (``data_loaders.display``) imported only when a notebook asks.

Kept apart from ``data_loaders.measured`` so that loading a file imports
nothing for display: Jupyter calls ``_repr_html_`` / ``_repr_png_``, which
import ``data_loaders.display`` (numpy, and Pillow for the PNG) on first use.
"""

import numpy as np


class MeasuredDisplay:
    """Mixin of MeasuredBRDF: short ``repr``, ``_repr_html_``, ``_repr_png_``."""

    def __repr__(self) -> str:
        p = self.provenance
        v = self.values[self.valid]
        span = f", {v.min():.3g}..{v.max():.3g} 1/sr" if v.size else ", no valid value"
        return (f"<MeasuredBRDF {p.material!r}: {p.format}, {len(self):,} samples "
                f"({int(np.count_nonzero(self.valid)):,} valid){span}, channels {''.join(self.channels)}>")

    def _repr_html_(self) -> str:
        from .display import measured_html
        return measured_html(self)

    def _repr_png_(self) -> bytes | None:
        from .display import measured_png
        try:
            return measured_png(self)
        except Exception:      # a display never raises; the HTML says why there is no sphere
            return None
