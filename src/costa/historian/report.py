"""What an import kept, dropped, blanked and cut, in words, and one plot a channel."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from ..data import write_trajectories  # noqa: E402
from ..variables import CHANNELS, INPUTS, label  # noqa: E402
from .grid import Imported  # noqa: E402

__all__ = ["report_markdown", "write_import"]


def report_markdown(report: dict) -> str:
    """The import report as a short Markdown page."""
    lines = [
        "# Import of a historian export",
        "",
        f"Grid: {report['steps']} steps of {report['step_s']:g} s from {report['start_utc']} (UTC); "
        f"{report['rows']} rows kept in {report['trajectories']} trajectories.",
        "",
        "| tag | to | unit | values | duplicates | steps with a value | bad quality dropped | empty |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for tag, t in report["tags"].items():
        lines.append(
            f"| {tag} | {t['to']} | {t['unit']} | {t['values']} | {t['duplicates']} | {t['steps_with_a_value']} | "
            f"{report['bad_quality'].get(tag, 0)} | {report['empty_values'].get(tag, 0)} |"
        )
    lines += ["", "**Cut** (an input without a value for longer than max_gap_s; left out):"]
    lines += [f"- from {c['start_utc']}, {c['seconds']:g} s" for c in report["cuts"]] or ["- none"]
    lines += ["", f"**Held** (an input's last value carried over a short gap), steps: {report['held_steps'] or 'none'}"]
    lines += ["", f"**Left over** (not a whole trajectory of trajectory_hours), steps: {report['left_over_steps']}"]
    lines += ["", "**Anode effects** (the voltage left empty from the start to anode_effect_after_s after the end):"]
    lines += [f"- {a['voltage']} from {a['start_utc']}, {a['seconds']:g} s" for a in report["anode_effects"]] or [
        "- none"
    ]
    lines += ["", f"**Anode changes cut** (each stretch ends at one, the next starts anode_change_after_s later): "
              f"{report['anode_change_cuts']}"]  # fmt: skip
    lines += ["", f"**Blanked** (outside the data contract's range), steps: {report['blanked'] or 'none'}"]
    lines += ["", "**Events** (placed in a trajectory / left out: in a cut or a left-over stretch):"]
    lines += [f"- {k}: {v['placed']} / {v['left_out']}" for k, v in report["events"].items()] or ["- none"]
    return "\n".join(lines) + "\n"


def plot_channels(record: pd.DataFrame, path: Path) -> None:
    """One panel a measured channel and logged input over the record's clock [h], trajectory by trajectory."""
    names = [c for c in INPUTS if c in record.columns and record[c].nunique() > 1]
    names += [c for c in CHANNELS if c in record.columns and record[c].notna().any()]
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.6 * len(names) + 0.5), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        for _, piece in record.groupby("trajectory"):
            hours, values = piece["time_s"] / 3600, piece[name]
            if values.notna().mean() > 0.5:  # logged: a line, broken where empty
                ax.plot(hours, values, "-", lw=0.6)
            else:  # sampled now and then: a point a sample
                ax.plot(hours[values.notna()], values.dropna(), "o", ms=3)
        ax.set_ylabel(label(name), fontsize=7)
    axes[-1, 0].set_xlabel("time since the grid's start [h]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_import(imported: Imported, folder: str | Path, provenance: dict) -> None:
    """record.parquet (the data contract), events.csv, import.json, import.md and channels.png in ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_trajectories(imported.record, folder / "record.parquet", provenance)
    imported.events.to_csv(folder / "events.csv", index=False)
    (folder / "import.json").write_text(json.dumps(imported.report, indent=1, default=_plain) + "\n")
    (folder / "import.md").write_text(report_markdown(imported.report))
    plot_channels(imported.record, folder / "channels.png")


def _plain(value):
    return value.item() if isinstance(value, np.generic) else str(value)
