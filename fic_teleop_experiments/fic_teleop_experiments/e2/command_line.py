"""The E2 command line: ``python -m fic_teleop_experiments.e2 trial|sweep|graph|bond-pulls ...``, each subcommand
with the options of its module (``... e2 sweep --help``)."""
from __future__ import annotations

import argparse
import importlib

#: subcommand -> (its module in this package, the function that runs it, one line of what it does)
SUBCOMMANDS = {
    "trial": ("trial", "run_trials", "in-process trials of seeds first..first+N-1, summarised (JSON, plot)"),
    "sweep": ("sweep", "run_sweep", "every law at every delay on the in-process runner, resumable (jsonl), on the "
                                    "engine; or its table, plots and failed pieces"),
    "graph": ("graph", "run_graph", "trials on the DDS graph in lockstep, resumable (jsonl); or their tables"),
    "bond-pulls": ("bond_pulls", "run_bond_pulls", "the bond's, the law's and the F/T force in each lock-and-pull "
                                                   "of one trial"),
}


def parser() -> argparse.ArgumentParser:
    """The command line's parser: one subparser a subcommand, built from its module's ``add_arguments``."""
    top = argparse.ArgumentParser(prog="python -m fic_teleop_experiments.e2", description=__doc__,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    subparsers = top.add_subparsers(dest="subcommand", required=True, metavar="SUBCOMMAND")
    for name, (module_name, run_name, summary) in SUBCOMMANDS.items():
        module = importlib.import_module(f"{__package__}.{module_name}")
        sub = subparsers.add_parser(name, help=summary, description=module.__doc__,
                                    formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(sub)
        sub.set_defaults(run=getattr(module, run_name), subparser=sub)
    return top


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    return args.run(args, args.subparser)

