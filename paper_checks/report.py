"""``derive prove --report DIR``: a Markdown and a LaTeX summary of the checks, and the same
verdicts for machines: ``prove.json`` and a JUnit XML file (``prove.xml``) that CI dashboards
read (a fail or an error is a JUnit failure or error; an erratum passes, its correction in the
case's output)."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import sympy as sp

from derive.notation import LATEX_NAMES


def _derived_latex(check_id: str) -> str | None:
    from derive.equations import BUILDERS, derived, render_latex
    if check_id not in BUILDERS:
        return None
    return render_latex(derived(check_id))


def _tex(expr) -> str:
    return sp.latex(expr, symbol_names=LATEX_NAMES)


def _escape_plain(text: str) -> str:
    out = []
    for ch in text:
        out.append({"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "_": r"\_",
                    "#": r"\#", "^": r"\textasciicircum{}", "~": r"\textasciitilde{}",
                    "$": r"\$", "{": r"\{", "}": r"\}"}.get(ch, ch))
    return "".join(out)


def _escape(text: str) -> str:
    """Text of CLAIMS.md and of the checks for LaTeX: its specials escaped, and its
    Markdown `code` spans set in \\texttt."""
    parts = text.split("`")
    if len(parts) % 2 == 0:                  # an unpaired backtick: no code spans
        return _escape_plain(text)
    return "".join(_escape_plain(p) if k % 2 == 0 else rf"\texttt{{{_escape_plain(p)}}}"
                   for k, p in enumerate(parts))


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", "<br>")


def write_report(out_dir, entries, outcomes) -> list[Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    by_id = {o.id: o for o in outcomes}
    md = ["# Checks of Markeev (2012) against the derivation", "",
          "| ID | claim | status | seconds | detail |", "|---|---|---|---|---|"]
    for e in entries:
        o = by_id[e.id]
        md.append(f"| {e.id} | {_cell(e.what)} | {o.status} | {o.seconds:.2f} | "
                  f"{_cell(o.detail)} |")
    errata = [er for o in outcomes for er in o.errata]
    md += ["", "## Errata", ""]
    md += [f"- **{er.id}**: printed `{er.printed}`; correct `{er.correct}`; "
           f"{er.consequence}." for er in errata] or ["None found."]
    md += ["", "## Derived expressions", ""]
    for e in entries:
        o = by_id[e.id]
        derived = _derived_latex(e.id)
        if not (o.shown or derived):
            continue
        md.append(f"### {e.id}: {e.what}")
        md.append("")
        if derived:
            md += ["```latex", derived, "```"]
        for label, expr in o.shown:
            md.append(f"- {label}: `{sp.sstr(expr)}`")
        md.append("")
    md_path = out / "prove.md"
    md_path.write_text("\n".join(md) + "\n", encoding="utf-8")

    tex = [r"\documentclass{article}", r"\usepackage{amsmath,longtable}",
           r"\begin{document}", r"\section*{Checks of Markeev (2012)}",
           r"\begin{longtable}{llrp{5.5cm}p{5.5cm}}",
           r"ID & status & s & claim & detail \\ \hline"]
    for e in entries:
        o = by_id[e.id]
        tex.append(f"{e.id} & {o.status} & {o.seconds:.2f} & {_escape(e.what)} & "
                   f"{_escape((o.detail or '').replace(chr(10), ' '))} \\\\")
    tex.append(r"\end{longtable}")
    tex.append(r"\subsection*{Errata}")
    if errata:
        tex.append(r"\begin{itemize}")
        for er in errata:
            tex.append(rf"\item {er.id}: printed \texttt{{{_escape(er.printed)}}}; correct "
                       rf"\texttt{{{_escape(er.correct)}}}; {_escape(er.consequence)}.")
        tex.append(r"\end{itemize}")
    else:
        tex.append("None found.")
    tex.append(r"\subsection*{Derived expressions}")
    for e in entries:
        o = by_id[e.id]
        derived = _derived_latex(e.id)
        if derived:
            tex.append(rf"\paragraph{{{e.id}}}")
            tex.append(derived.replace(r"\begin{align}", r"\begin{align*}")
                       .replace(r"\end{align}", r"\end{align*}"))
        for label, expr in o.shown:
            tex.append(rf"\paragraph{{{e.id}, {_escape(label)}}} $\displaystyle {_tex(expr)}$")
    tex.append(r"\end{document}")
    tex_path = out / "prove.tex"
    tex_path.write_text("\n".join(tex) + "\n", encoding="utf-8")
    return [md_path, tex_path, *_write_machine(out, entries, by_id)]


def _erratum(er) -> dict:
    return {"id": er.id, "printed": er.printed, "correct": er.correct,
            "consequence": er.consequence}


def _write_machine(out: Path, entries, by_id) -> list[Path]:
    """prove.json (one record per ID, in the catalogue's order) and prove.xml (JUnit: one
    test case per ID, classname its section)."""
    records = [{"id": e.id, "section": e.section, "claim": e.what, "status": by_id[e.id].status,
                "seconds": round(by_id[e.id].seconds, 4), "detail": by_id[e.id].detail or "",
                "errata": [_erratum(er) for er in by_id[e.id].errata]} for e in entries]
    json_path = out / "prove.json"
    json_path.write_text(json.dumps({"checks": records}, indent=1, ensure_ascii=False) + "\n",
                         encoding="utf-8")
    failed = sum(r["status"] in ("fail", "missing") for r in records)
    errors = sum(r["status"] == "error" for r in records)
    suite = ET.Element("testsuite", name="derive prove", tests=str(len(records)),
                       failures=str(failed), errors=str(errors),
                       time=f"{sum(r['seconds'] for r in records):.3f}")
    for r in records:
        case = ET.SubElement(suite, "testcase", classname=f"paper_checks.{r['section']}",
                             name=r["id"], time=f"{r['seconds']:.3f}")
        if r["status"] in ("fail", "missing"):
            ET.SubElement(case, "failure", message=r["status"]).text = r["detail"]
        elif r["status"] == "error":
            ET.SubElement(case, "error", message="error").text = r["detail"]
        lines = [r["detail"]] + [f"erratum {er['id']}: printed {er['printed']}; correct "
                                 f"{er['correct']}; {er['consequence']}" for er in r["errata"]]
        ET.SubElement(case, "system-out").text = "\n".join(x for x in lines if x)
    xml_path = out / "prove.xml"
    root = ET.Element("testsuites")
    root.append(suite)
    ET.indent(root)
    xml_path.write_bytes(ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n")
    return [json_path, xml_path]
