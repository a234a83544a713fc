"""The ``brdf-fit`` command line."""

import argparse
import sys

from brdf import __version__


def _cmd_models(args):
    from brdf.model import MODEL_EXAMPLES, describe_tokens
    print("model strings: NDF[+diffuse][+options], e.g.")
    for name in MODEL_EXAMPLES:
        print(f"  {name}")
    print(describe_tokens())
    return 0


def _cmd_info(args):
    from data_loaders.cli import info_main
    return info_main(args.file)


def _cmd_eval(args):
    from data_loaders.cli import eval_main
    return eval_main(args.file, args.directions, args.out)


def build_parser():
    parser = argparse.ArgumentParser(
        prog="brdf-fit",
        description="Fit analytic BRDF models to measured reflectance data.")
    parser.add_argument("--version", action="version", version=f"brdf-fit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("models", help="list the model strings")
    p.set_defaults(func=_cmd_models)

    p = sub.add_parser("info", help="summarise a measured BRDF file")
    p.add_argument("file")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("eval", help="evaluate a measured file (or a fit result) at direction pairs")
    p.add_argument("file", help="measured BRDF file or RESULT.json")
    p.add_argument("directions", help=".npy float array N x 6: wi then wo, local frame")
    p.add_argument("out", help=".npy output, N x 3 RGB in 1/sr (float64)")
    p.set_defaults(func=_cmd_eval)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
