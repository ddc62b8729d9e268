"""Comparisons turned into tables (field names, rows) for runout:comparelayouts. No QGIS import: the test checks
these conversions with plain Python (tests/qgis/provider_test.py)."""


def table_of(compare):
    """`runout compare --format json` turned round: (field names, rows), one row per layout (the baseline
    first), a value and its per cent against the baseline per metric, and `<metric>_never` (1/0) for metrics
    where some layout's arrival never happened."""
    metrics = [r["metric"] for r in compare["rows"]]
    never = [r["metric"] for r in compare["rows"] if r["baseline_never"] or any(r["never"])]
    names = ["layout", "run_id", "baseline"] + [n for m in metrics for n in (m, m + "_pct")] + [m + "_never" for m in never]
    rows = [[compare["baseline"], compare["baseline_id"], 1]
            + [v for r in compare["rows"] for v in (r["baseline"], 0.0 if r["baseline"] is not None else None)]
            + [int(r["baseline_never"]) for r in compare["rows"] if r["metric"] in never]]
    for k, label in enumerate(compare["runs"]):
        rows.append([label, compare["run_ids"][k], 0]
                    + [v for r in compare["rows"] for v in (r["values"][k], r["percent"][k])]
                    + [int(r["never"][k]) for r in compare["rows"] if r["metric"] in never])
    return names, rows


def cli_compare_of_service(doc, all_metrics):
    """The service's `GET /compare` document (docs/service.md) in the shape of `runout compare --format json`,
    so both give the same table: the decision metrics only unless all_metrics (the CLI's --all), and the
    layouts after the baseline by name, as `runout compare --sweep` orders them (the service keeps the
    submission order)."""
    jobs = doc["jobs"]
    order = sorted(range(len(jobs)), key=lambda k: jobs[k]["label"])
    rows = [{"metric": r["metric"], "decision": r["decision"], "baseline": r["baseline"],
             "baseline_never": r["baseline_never"], "values": [r["values"][k] for k in order],
             "never": [r["never"][k] for k in order], "percent": [r["percent"][k] for k in order]}
            for r in doc["metrics"] if all_metrics or r["decision"]]
    return {"baseline": doc["baseline"]["label"], "baseline_id": doc["baseline"]["run_id"],
            "runs": [jobs[k]["label"] for k in order], "run_ids": [jobs[k]["run_id"] for k in order],
            "outlet": doc.get("outlet"), "rows": rows}


def is_ensemble(compare):
    """An ensemble sweep's summary (ensemble_summary.hpp) rather than a plain comparison."""
    return "layouts_detail" in compare


ENSEMBLE_STATS = ("p10", "p50", "p90", "never")


def ensemble_table_of(summary, baseline=None):
    """An ensemble summary (`runout compare --sweep NAME --format json` of an ensemble sweep:
    {sweep, layouts, members, ..., layouts_detail: {LAYOUT: {first_share, metrics: {METRIC: {p10, p50, p90,
    count, never}}}}}) as (field names, rows): one row per layout, the baseline (default: the summary's first
    layout) first, its share of first places and per metric the p10, p50 and p90 over the members and how many
    members never arrived. Empty where a layout has no such metric (a structure it does not build) or no member
    has a value (every one never arrived). Raises ValueError for a baseline that is not a layout."""
    layouts = list(summary["layouts"])
    if baseline:
        if baseline not in layouts:
            raise ValueError(f"'{baseline}' is not a layout of ensemble {summary['sweep']} (its layouts: "
                             + ", ".join(layouts) + ")")
        layouts.remove(baseline)
        layouts.insert(0, baseline)
    detail = summary["layouts_detail"]
    metrics = []  # every layout's metrics, in the summary's order (the decision metrics by rank)
    for layout in summary["layouts"]:
        metrics += [m for m in detail[layout]["metrics"] if m not in metrics]
    names = ["layout", "first_share"] + [f"{m}_{s}" for m in metrics for s in ENSEMBLE_STATS]
    rows = []
    for layout in layouts:
        d = detail[layout]
        rows.append([layout, d["first_share"]]
                    + [d["metrics"].get(m, {}).get(s) for m in metrics for s in ENSEMBLE_STATS])
    return names, rows


def field_kind(name):
    """The type of a table's field: text for the layout, an integer for ids, flags and counts, else a double."""
    if name == "layout":
        return "text"
    if name in ("run_id", "baseline") or name.endswith("_never"):
        return "int"
    return "double"
