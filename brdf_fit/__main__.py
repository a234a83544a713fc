"""``python -m brdf_fit`` and the ``brdf-fit`` console script: the command line
(brdf_fit.cli), after a check that the libraries it imports are this distribution's
(brdf_fit.origin: a ``fitting.py`` in the working directory is one line, not a traceback)."""

import sys


def run() -> None:
    from brdf_fit.origin import shadowed
    line = shadowed()
    if line:
        from brdf_fit.errors import BAD_INPUT, printable
        print(printable(f"brdf-fit: {line}"), file=sys.stderr)
        sys.exit(BAD_INPUT)
    from brdf_fit.cli import run as run_command_line
    run_command_line()


if __name__ == "__main__":
    run()
