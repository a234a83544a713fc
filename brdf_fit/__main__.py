"""``python -m brdf_fit``: the ``brdf-fit`` command."""

import sys

from brdf_fit.cli import main

if __name__ == "__main__":
    sys.exit(main())
