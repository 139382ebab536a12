"""Tables 1-3 and the all-metrics table, in Markdown or LaTeX, from summaries of records.

``summaries(records)[task][scene_set][method]`` is a :func:`scdp.evaluation.records.summarize`
result. "Spatial ambiguity" is our ``ambiguous`` set and "No spatial ambiguity" our
``non_ambiguous`` set (random scenes labelled by eq. 3); the six layouts are also grouped as
the authors labelled them (``layouts_ambiguous``: 1-3, ``layouts_clear``: 4-6). Table 3 sets
the two protocols side by side on those layouts. Each summary also carries ``success_ci``, the
success rate with its 95 % Wilson interval counted on scenes
(:func:`scdp.evaluation.statistics.success_rate`).
"""

from __future__ import annotations

from scdp import planners
from scdp.evaluation.paper import PAPER_DE, PAPER_T
from scdp.evaluation.records import TrajectoryRecord, summarize
from scdp.evaluation.statistics import success_rate
from scdp.keys import AMBIGUOUS, AMBIGUOUS_LAYOUTS, CLEAR, CLEAR_LAYOUTS, layout_name, layout_number
from scdp.tasks import get_task

METHOD_NAMES = {"dp": "Diffusion Policy", "ld": "Legibility Diffuser", "scdp": "Ours (SCDP)", "dataset": "Dataset"}
TASK_TITLES = {"block_reach": "Block Reach", "navigation": "Navigation"}
TASK_ORDER = ("block_reach", "navigation")
SETS = (AMBIGUOUS, CLEAR)
LAYOUT_GROUPS = (AMBIGUOUS_LAYOUTS, CLEAR_LAYOUTS)
PROTOCOL_NAMES = {"random": "random-scene models", "per_layout": "per-layout models"}
DATASET = "dataset"  # the generator's demonstrations: a row of the tables, not a method


def task_title(name: str) -> str:
    """A task's title in tables and figures (a task of your own: its name, capitalised)."""
    return TASK_TITLES.get(name, name.replace("_", " ").capitalize())


def ordered_tasks(names) -> list[str]:
    """Task names in the report's order: the paper's two first, any other after them, by name."""
    names = set(names)
    return [t for t in TASK_ORDER if t in names] + sorted(names - set(TASK_ORDER))


def ordered_methods(names) -> list[str]:
    """Method names in report order: the paper's rows, then every planner, then the rest sorted."""
    known = [*METHOD_NAMES, *(m for m in planners.names() if m not in METHOD_NAMES)]
    names = set(names)
    return [m for m in known if m in names] + sorted(names - set(known))


def _summarize(records: list[TrajectoryRecord]) -> dict:
    return {**summarize(records), "success_ci": success_rate(records)}


def summaries(records: list[TrajectoryRecord]) -> dict:
    """summary[task][scene_set][method]; layouts also grouped as ``layouts_ambiguous`` / ``layouts_clear``."""
    out: dict = {}
    for task in sorted({r.task for r in records}):
        ambiguous = {layout_name(i) for i in get_task(task).ambiguous_layouts}
        groups: dict = {}
        for r in (r for r in records if r.task == task):
            groups.setdefault(r.scene_set, {}).setdefault(r.method, []).append(r)
            if layout_number(r.scene_set) is not None:
                key = AMBIGUOUS_LAYOUTS if r.scene_set in ambiguous else CLEAR_LAYOUTS
                groups.setdefault(key, {}).setdefault(r.method, []).append(r)
        out[task] = {s: {m: _summarize(rs) for m, rs in ms.items()} for s, ms in groups.items()}
    return out


def mean_pm_std(stat: dict) -> str:
    """'0.52 ± 0.06' from a {'mean', 'std'} summary."""
    return f"{stat['mean']:.2f} ± {stat['std']:.2f}"


def paper_pm(pair) -> str:
    """'0.52 ± 0.06' from the paper's (mean, std); '–' where the paper has none (a task of your own)."""
    return "–" if pair is None else f"{pair[0]:.2f} ± {pair[1]:.2f}"


NO_PAPER = (None, None)  # (ambiguous, clear) of a task the paper does not have


def paper_t(task: str, method: str):
    """The paper's T (ambiguous, clear) of ``method`` on ``task``, or :data:`NO_PAPER`."""
    return PAPER_T.get(task, {}).get(method, NO_PAPER)


def paper_de(task: str, method: str):
    """The paper's ((D, E) ambiguous, (D, E) clear) of ``method`` on ``task``, or Nones."""
    return PAPER_DE.get(task, {}).get(method, (NO_PAPER, NO_PAPER))


def captioned(caption: str, reading: str) -> str:
    """A table's caption with the normalisation it is read under (none given: as it is)."""
    return caption[:-1] + f"; {reading})" if reading else caption


def table1(summary: dict, fmt: str = "md", reading: str = "") -> str:
    """Adaptive transparency score T, ours beside the paper's; ``reading``: the normalisation, for the caption."""
    head = ["Method", "Ambiguous (ours)", "Ambiguous (paper)", "Not ambiguous (ours)", "Not ambiguous (paper)"]
    rows = []
    for task in ordered_tasks(summary):
        rows.append([f"*{task_title(task)}*"] + [""] * 4)
        for m in METHOD_NAMES:
            ours = [summary[task][s][m]["transparency"] for s in SETS]
            paper = paper_t(task, m)
            rows.append([METHOD_NAMES[m], mean_pm_std(ours[0]), paper_pm(paper[0]), mean_pm_std(ours[1]), paper_pm(paper[1])])
    return render(head, rows, fmt, captioned("Table 1: adaptive transparency score T (mean ± std)", reading))


def table2(summary: dict, fmt: str = "md", reading: str = "") -> str:
    """Normalised detachment and efficiency, ours beside the paper's; ``reading`` as for :func:`table1`."""
    head = ["Method", "D amb. (ours)", "D amb. (paper)", "E amb. (ours)", "E amb. (paper)",
            "D clear (ours)", "D clear (paper)", "E clear (ours)", "E clear (paper)"]
    rows = []
    for task in ordered_tasks(summary):
        rows.append([f"*{task_title(task)}*"] + [""] * 8)
        for m in METHOD_NAMES:
            cells = [METHOD_NAMES[m]]
            for i, s in enumerate(SETS):
                st = summary[task][s][m]
                (pd, pe) = paper_de(task, m)[i]
                cells += [mean_pm_std(st["d_hat"]), paper_pm(pd), mean_pm_std(st["e_hat"]), paper_pm(pe)]
            rows.append(cells)
    return render(head, rows, fmt, captioned("Table 2: normalised detachment D and efficiency E (mean ± std)", reading))


def success_cell(stat: dict) -> str:
    """'0.77 [0.68, 0.84]' from a summary: the success rate and its 95 % interval (rate alone if absent)."""
    ci = stat.get("success_ci")
    return f"{stat['success']['mean']:.2f}" + (f" [{ci['lo']:.2f}, {ci['hi']:.2f}]" if ci else "")


def metrics_table(summary: dict, beta: float) -> str:
    """T, the failure-aware T_fa, D, E, Dragan legibility, success with its 95 % interval (Wilson,
    n = distinct scenes) and planning time, on the random sets and the layout groups."""
    head = ["Task", "Scene set", "Method", "n", "scenes", "T", "T_fa", "D", "E", f"legibility (β={beta:g})",
            "success [95 % CI]", "s / traj"]
    rows = []
    for task, sets in summary.items():
        for s in (s for s in SETS + LAYOUT_GROUPS if s in sets):
            for m in ordered_methods(sets[s]):
                st = sets[s][m]
                fa = mean_pm_std(st["transparency_fa"]) if "transparency_fa" in st else "–"
                scenes = str(st["success_ci"]["scenes"]) if "success_ci" in st else "–"
                rows.append([task_title(task), s, METHOD_NAMES.get(m, m), str(st["n"]), scenes, mean_pm_std(st["transparency"]),
                             fa, mean_pm_std(st["d_hat"]), mean_pm_std(st["e_hat"]), mean_pm_std(st["legibility"]),
                             success_cell(st), f"{st['seconds']['mean']:.3f}"])
    return render(head, rows, "md", "All metrics per scene set (T_fa: failure-aware T; success interval: Wilson, "
                                    "n = distinct scenes)")


def table3(by_protocol: dict, fmt: str = "md", reading: str = "") -> str:
    """The six layouts under both protocols, with the paper's numbers (T, D, E).

    ``by_protocol[protocol]`` is a :func:`summaries` result; protocols that were not run are
    left out. Ambiguous = layouts 1-3, clear = 4-6, as the authors labelled them.
    """
    head = ["Method", "Models"] + [f"{k} {s}" for s in ("amb.", "clear") for k in ("T", "D", "E", "success")]
    rows = []
    tasks = ordered_tasks({t for summary in by_protocol.values() for t in summary})
    for task in tasks:
        rows.append([f"*{task_title(task)}*"] + [""] * (len(head) - 1))
        for m in METHOD_NAMES:
            for protocol, summary in by_protocol.items():
                if m == "dataset" and protocol != "random" and "random" in by_protocol:
                    continue  # the Dataset row does not depend on the models
                cells = [METHOD_NAMES[m], "generated demos" if m == "dataset" else PROTOCOL_NAMES[protocol]]
                for s in LAYOUT_GROUPS:
                    st = summary[task].get(s, {}).get(m)
                    cells += ([mean_pm_std(st["transparency"]), mean_pm_std(st["d_hat"]), mean_pm_std(st["e_hat"]),
                               f"{st['success']['mean']:.2f}"] if st else ["–"] * 4)
                rows.append(cells)
            cells = [METHOD_NAMES[m], "paper"]
            for i in range(2):
                (pd, pe) = paper_de(task, m)[i]
                cells += [paper_pm(paper_t(task, m)[i]), paper_pm(pd), paper_pm(pe), "–"]
            rows.append(cells)
    return render(head, rows, fmt, captioned("Table 3: the six fixed layouts, random-scene vs per-layout models (mean ± std)",
                                             reading))


def render(head: list[str], rows: list[list[str]], fmt: str, caption: str) -> str:
    """A table as Markdown (``fmt='md'``) or a LaTeX ``table`` with booktabs rules."""
    if fmt == "md":
        lines = [f"**{caption}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(r) + " |" for r in rows]
        return "\n".join(lines) + "\n"
    esc = lambda t: t.replace("±", r"$\pm$").replace("*", "").replace("_", r"\_")  # noqa: E731
    lines = [r"\begin{table}[tbp]", r"\centering", rf"\caption{{{caption}}}", r"\small",
             r"\begin{tabular}{l" + "c" * (len(head) - 1) + "}", r"\toprule", " & ".join(esc(h) for h in head) + r" \\", r"\midrule"]
    for r in rows:
        if all(c == "" for c in r[1:]):
            lines.append(rf"\multicolumn{{{len(head)}}}{{l}}{{\textit{{{esc(r[0])}}}}} \\")
        else:
            lines.append(" & ".join(esc(c) for c in r) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"
