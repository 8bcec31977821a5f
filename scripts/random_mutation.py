#!/usr/bin/env python3
"""Seeded random mutation testing over all of fic_core against test/core (sim_bridge/tools/random_mutation.py);
beside the hand-picked mutations of scripts/mutation_check.py.

    source scripts/env.sh && python scripts/random_mutation.py --seed 1 --sample 60 [--out results/random_mutation.json]
    python scripts/random_mutation.py --count          # how many sites fic_core has, per kind
    python scripts/random_mutation.py --seed 1 --sample 60 --list   # the sample, without running it

Exits 1 when the kill rate of the non-equivalent mutants is below --require (default 0.9).
"""
from __future__ import annotations

import argparse
import collections
import json
import sys
from pathlib import Path

from sim_bridge.tools import random_mutation


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--sample", type=int, default=60, help="mutants drawn from all of fic_core's sites")
    parser.add_argument("--module", default=None, help="draw from this fic_core file only (e.g. limits.py)")
    parser.add_argument("--timeout", type=float, default=240.0, help="seconds for the tests of one mutant")
    parser.add_argument("--out", type=Path, default=None, help="write every verdict as JSON")
    parser.add_argument("--require", type=float, default=0.9, help="least kill rate of the non-equivalent mutants")
    parser.add_argument("--commit", default="HEAD", help="the commit whose fic_core and test/core are run")
    parser.add_argument("--rerun", type=Path, default=None,
                        help="run the survivors of an earlier --out JSON again (found by module, line text, change)")
    parser.add_argument("--list", action="store_true", help="print the sample and exit")
    parser.add_argument("--count", action="store_true", help="print the number of sites per kind and exit")
    arguments = parser.parse_args()
    if arguments.count:
        sites = random_mutation.all_sites()
        for kind, count in sorted(collections.Counter(site.kind for site in sites).items()):
            print(f"{kind:12s} {count}")
        print(f"{'all':12s} {len(sites)}")
        return 0
    if arguments.list:
        for site in random_mutation.sample(arguments.seed, arguments.sample, arguments.module):
            print(f"{site.module}:{site.line} {site.kind}: {site.change}    {site.source_line[:90]}")
        return 0
    result = random_mutation.run(arguments.seed, arguments.sample, arguments.timeout, arguments.module,
                                 arguments.out, echo=lambda text: print(text, flush=True),
                                 commit=arguments.commit,
                                 rerun=json.loads(arguments.rerun.read_text()) if arguments.rerun else None)
    print(f"commit {result['commit'][:10]}, seed {result['seed']}: {result['sample']} mutants of {result['sites']} "
          f"sites, {result['equivalent']} equivalent; killed {result['killed']} of {result['non_equivalent']} "
          f"(kill rate {result['kill_rate']}) in {result['seconds']} s")
    return 0 if result["kill_rate"] is not None and result["kill_rate"] >= arguments.require else 1


if __name__ == "__main__":
    sys.exit(main())
