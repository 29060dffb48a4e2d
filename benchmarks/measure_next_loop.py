"""Does "what to measure next" help? The closed loop on the shipped cases under a sensor set.

For each case whose findings under ``--sensors`` (default pot_line) end undecided or unexplained
with a recommendation, adds the top recommended measurement to that sensor set (as the set
``<sensors>_next``), runs the case again through the workflow, and prints one row per case:
the outcome before and after, the measurement added and whether the hidden effect is then
named.  Run from the repository root after the case's findings exist:

    python benchmarks/measure_next_loop.py [--sensors pot_line] [--cases alumina_feeder ...] [--cores 2]

The extended config goes to results/measure_next/config.yaml; the reruns' findings to
results/discovery/<case>/sensors/<sensors>_next/.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import yaml

from costa.config import load_config
from costa.discover.cases.unshipped import find_case

RESULTS = Path("results")


def findings(case: str, sensors: str) -> dict:
    return json.loads((RESULTS / "discovery" / case / "sensors" / sensors / "findings.json").read_text())


def top_recommendation(found: dict, measured: set[str]) -> dict | None:
    """The first round's top recommendation of a channel the set does not measure, where it ended
    without a name (the pot voltage counts as the cell voltage, as findings made since
    2026-11-26 rank them)."""
    first = found["rounds"][0]
    if found["named"]:
        return None
    measured = measured | ({"U_cell"} if "U_pot" in measured else set())
    return next((m for m in first.get("measure_next", []) if m["channel"] not in measured), None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sensors", default="pot_line")
    parser.add_argument("--cases", nargs="*")
    parser.add_argument("--cores", type=int, default=2)
    args = parser.parse_args()
    config = load_config("config/config.yaml", "config/sensors.yaml")
    cases = args.cases or config["discovery"]["cases"]
    base = config["discovery"]["sensor_sets"][args.sensors]
    extended, rows = f"{args.sensors}_next", []
    recommended = {case: top_recommendation(findings(case, args.sensors), set(base["channels"])) for case in cases}
    added = {case: r for case, r in recommended.items() if r is not None}
    if not added:
        print("no case ends without a name and with a recommendation")
        return
    # one added channel per case: each case gets its own set, named after the set and the case
    sets = {
        f"{extended}_{case}": {
            **base,
            "channels": {**base["channels"], r["channel"]: {"every_s": r["every_s"], "noise": r["noise"]}},
        }
        for case, r in added.items()
    }
    overlay = {"discovery": {"cases": list(added), "sensors": [args.sensors], "sensor_sets": sets}}
    folder = RESULTS / "measure_next"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yaml").write_text(yaml.safe_dump(overlay, sort_keys=False))
    targets = [str(RESULTS / "discovery" / c / "sensors" / f"{extended}_{c}" / "findings.json") for c in added]
    command = [sys.executable, "-m", "snakemake", "--cores", str(args.cores), "--keep-going", *targets,
               "--configfile", "config/sensors.yaml", str(folder / "config.yaml")]  # fmt: skip
    subprocess.run(command, check=False)
    for case, r in added.items():
        before = findings(case, args.sensors)
        path = RESULTS / "discovery" / case / "sensors" / f"{extended}_{case}" / "findings.json"
        after = json.loads(path.read_text()) if path.exists() else None
        accepted = set(find_case(case).accepted)
        rows.append({
            "case": case, "before": before["outcome"], "added": f"{r['channel']} every {r['every_s']:g} s",
            "separation": r["separation_noise_stds"], "after": after["outcome"] if after else "failed",
            "named": (after or {}).get("named", []), "right": bool(accepted & set((after or {}).get("named", []))),
        })  # fmt: skip
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
