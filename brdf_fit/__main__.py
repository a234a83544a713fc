"""``python -m brdf_fit``: the ``brdf-fit`` command."""

from brdf_fit.cli import run

if __name__ == "__main__":
    run()
