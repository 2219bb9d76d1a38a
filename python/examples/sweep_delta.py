"""The paper's δ grid and its ablation (Fig. 6) as one Ray sweep each.

    python python/examples/sweep_delta.py OUT_DIR [--address ray://host:10001] [--quick]

- δ grid: `u_obstacle` at δ ∈ {0.05, 0.2, 0.4} (Table I in docs/experiments.md).
- ablation: `swing` and `drop` × {G, G+αT, G+βE, G+αT+βE}: α and β at 0 or the scene's own
  weights, without the safety constraint (neither scene has a safety obstacle).

Each task writes OUT_DIR/<grid>/<task>.json and a summary.csv; run it again to resume.
`--quick` caps the optimizer at 5 iterations (a smoke run of the whole pipeline).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import clothopt

DELTA_GRID = {"delta": [0.05, 0.2, 0.4]}
# None = the scene's own weight; 0.0 drops the term.
ABLATION_GRID = [
    {"alpha": 0.0, "beta": 0.0},   # G
    {"alpha": None, "beta": 0.0},  # G + αT
    {"alpha": 0.0, "beta": None},  # G + βE
    {"alpha": None, "beta": None},  # G + αT + βE
]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--address", default=None, help="a Ray cluster (default: a local instance)")
    parser.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local instance")
    parser.add_argument("--quick", action="store_true", help="5 optimizer iterations per task")
    args = parser.parse_args()

    extra = {"iterations": 5, "search": "off"} if args.quick else {}
    delta_grid = {**DELTA_GRID, **{k: [v] for k, v in extra.items()}}
    ablation_grid = [{**point, **extra} for point in ABLATION_GRID]
    common = {"address": args.address, "num_cpus": args.num_cpus}

    delta_rows = clothopt.sweep(["u_obstacle"], delta_grid, args.out_dir / "delta", **common)
    ablation_rows = clothopt.sweep(["swing", "drop"], ablation_grid, args.out_dir / "ablation",
                                   **common)
    writer = csv.writer(sys.stdout)
    writer.writerow(["task", "status", "achieved", "L", "G", "T", "E", "min_sdf"])
    for r in delta_rows + ablation_rows:
        writer.writerow([r["task"], r["status"], r["achieved"], r["L"], r["G"], r["T"], r["E"],
                         r["min_sdf"]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
