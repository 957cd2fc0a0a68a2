"""A sweep's results, summarised: a table of mean and worst per group (the swept values other
than the seed) and a plot of the metrics across the swept axes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from quadsim.apps.sweep.metrics import METRICS

#: the metrics the summary and the plot show (the table has them all)
SHOWN = ("tracking_rms_mps", "max_tilt_deg", "end_drift_m", "crashes", "touchdown_speed_mps")


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if isinstance(v, float) and not math.isnan(v)]


def group_rows(rows: Sequence[dict[str, Any]], varied: Sequence[str]) -> dict[tuple[str, ...], list[dict[str, Any]]]:
    groups: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for r in sorted(rows, key=lambda r: r["index"]):
        groups.setdefault(tuple(str(r[a]) for a in varied), []).append(r)
    return groups


def summary_lines(rows: Sequence[dict[str, Any]], varied: Sequence[str]) -> list[str]:
    """Mean and worst of each shown metric per group, then the counts by status."""
    shown = [m for m in SHOWN if _finite([r[m] for r in rows])]
    head = [*varied, "runs", *(f"{m} mean/worst" for m in shown)]
    table = [head]
    for key, group in group_rows(rows, varied).items():
        cells = [*key, str(len(group))]
        for m in shown:
            values = _finite([r[m] for r in group])
            cells.append(f"{sum(values) / len(values):.3g} / {max(values):.3g}" if values else "-")
        table.append(cells)
    widths = [max(len(row[i]) for row in table) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in table]
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "fail", "error")}
    lines.append(
        f"{len(rows)} run{'s' * (len(rows) != 1)}: {counts['ok']} ok, {counts['fail']} beyond limits, {counts['error']} could not fly"
    )
    for r in rows:
        if r["status"] == "error":
            lines.append(f"  run {r['index']} ({r['key']}): {r['error']}")
            break
    return lines


def _numeric(value: str) -> float | None:
    """The number a swept value stands for on a plot axis (wind "5,90" -> 5 m/s)."""
    try:
        return float(value.split(",")[0])
    except ValueError:
        return None


def _series(
    group: Sequence[dict[str, Any]], metric: str, x_axis: str, position: dict[str, Any]
) -> tuple[list[Any], list[float], list[float], list[float]]:
    """One plotted line: at each x the group's runs have, the mean, least and most of `metric`."""
    xs, means, lows, highs = [], [], [], []
    for v, x in position.items():
        values = _finite([r[metric] for r in group if str(r[x_axis]) == v])
        if values:
            xs.append(x)
            means.append(sum(values) / len(values))
            lows.append(min(values))
            highs.append(max(values))
    return xs, means, lows, highs


def plot(rows: Sequence[dict[str, Any]], varied: Sequence[str], path: Path, title: str) -> Path | None:
    """Each shown metric against the first swept axis (numbers on a numeric axis), one line per
    combination of the other swept values, the band between the best and worst seed. None: no
    metric to draw (no run flew, or every metric is zero in every run)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # on the x axis: the first swept axis whose values are numbers (the wind speed), else the first
    numeric_axes = [a for a in varied if all(_numeric(str(r[a])) is not None for r in rows)]
    x_axis = numeric_axes[0] if numeric_axes else varied[0] if varied else "scenario"
    others = [a for a in varied if a != x_axis]
    # a metric that is zero everywhere (no crash in any run) says so in the summary, not as a plot
    shown = [m for m in SHOWN if any(v != 0.0 for v in _finite([r[m] for r in rows]))]
    if not shown:
        return None
    fig, axes = plt.subplots(len(shown), 1, figsize=(7.5, 2.2 * len(shown) + 0.8), sharex=True, squeeze=False)
    xs_all = sorted({str(r[x_axis]) for r in rows}, key=lambda v: (_numeric(v) is None, _numeric(v) or 0.0, v))
    numeric = all(_numeric(v) is not None for v in xs_all)
    position = {v: (_numeric(v) if numeric else i) for i, v in enumerate(xs_all)}
    lines = group_rows(rows, others)
    for ax, metric in zip(axes[:, 0], shown):
        for label, group in sorted(lines.items()):
            xs, means, lows, highs = _series(group, metric, x_axis, position)
            name = ", ".join(f"{a}={v}" for a, v in zip(others, label)) or "all runs"
            # categories are not a scale: no line between them
            (line,) = ax.plot(xs, means, marker="o", linestyle="-" if numeric else "none", label=name)
            if not numeric:  # the spread over seeds as error bars
                ax.errorbar(
                    xs,
                    means,
                    yerr=[[m - lo for m, lo in zip(means, lows)], [hi - m for m, hi in zip(means, highs)]],
                    fmt="none",
                    ecolor=line.get_color(),
                    capsize=3,
                )
            if numeric and any(lo != hi for lo, hi in zip(lows, highs)):
                ax.fill_between(xs, lows, highs, color=line.get_color(), alpha=0.18, linewidth=0)
        ax.set_ylabel(metric.replace("_", " "), fontsize=8)
        ax.grid(True, alpha=0.3)
        ax.set_title(METRICS[metric], fontsize=8, loc="left")
    bottom = axes[-1, 0]
    if not numeric:
        bottom.set_xticks(list(position.values()), xs_all)
    bottom.set_xlabel("wind speed (m/s)" if x_axis == "wind" else x_axis)
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
