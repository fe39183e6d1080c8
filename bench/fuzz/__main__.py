"""``python -m bench.fuzz``: fuzz every input of the station, print JSON (see the package)."""

from __future__ import annotations

import argparse
import json
import logging
import sys

from bench.fuzz.run import KINDS, fuzz


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.fuzz", description=__doc__)
    parser.add_argument("--n", type=int, default=10_000, help="inputs of each kind")
    parser.add_argument("--kinds", default=",".join(KINDS), help="comma-separated subset")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = sorted(set(kinds) - set(KINDS))
    if unknown or args.n < 1:
        parser.error(f"kinds must be among {', '.join(KINDS)} and n >= 1")
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    result = fuzz(args.n, kinds=kinds, seed=args.seed)
    print(json.dumps(result, indent=2))
    return 0 if result["bars_met"] else 1


if __name__ == "__main__":
    sys.exit(main())
