"""The README's two commands stay true: CI runs the README's test command verbatim."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.findall(r"```sh\n(.+?)\n```", text)


def test_readme_opens_with_two_commands():
    commands = readme_commands()
    assert len(commands) >= 2
    install = "pip install -e '.[test]'"
    assert all(install in c for c in commands[:2])


def test_ci_runs_the_readme_test_command():
    test_command = readme_commands()[1].split("&&")[-1].strip()
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test_command in [line.strip() for line in ci], \
        f".ci/run does not run the README's test command {test_command!r}"


def test_readme_documents_the_state_layouts_as_the_code_has_them():
    from derive.models import STATE_LABELS
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    flat = " ".join(text.split())
    for model, labels in STATE_LABELS.items():
        assert f"`{model}`, {len(labels)} states: `({', '.join(labels)})`" in flat, model


def test_readme_schema_table_is_the_schema():
    """The scene schema is written once: the README's table is rendered from it."""
    from derive.scene import schema_table
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("<!-- schema:begin -->\n", 1)[1].split("<!-- schema:end -->", 1)[0]
    assert block.strip() == schema_table().strip(), \
        "README schema table differs: paste the output of `python -m derive scene schema`"


def test_readme_python_examples_run(tmp_path, monkeypatch, capsys):
    """Every ```python block of the README runs as written (in a scratch folder); the
    guide's new shape is code for derive/shapes.py, run by tests/test_regenerate.py in a
    scratch copy."""
    import re
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    text = re.sub(r"<!-- shape-example -->\n```python\n.*?```", "", text, flags=re.S)
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    out = capsys.readouterr().out
    assert "done" in out and "<Plan reorient: solved; 16 pieces over 2 s>\nTrue" in out


def test_readme_layout_names_every_module_of_derive():
    """The README's layout of derive/ names every module and package there is, and none
    that is gone."""
    import re
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    layout = text.split("`derive/`, in the order data flows:", 1)[1]
    first = [row.split("|")[1] for row in layout.splitlines()
             if row.startswith("| `")]                        # the module column
    named = {n for cell in first for n in re.findall(r"`([a-z_]+)/?`", cell)}
    have = {p.stem for p in (ROOT / "derive").glob("*.py")
            if p.stem not in ("__init__", "__main__")}
    have |= {p.name for p in (ROOT / "derive").iterdir()
             if p.is_dir() and (p / "__init__.py").is_file()}
    assert not have - named, f"not in the README's layout: {sorted(have - named)}"
    assert not named - have, f"in the README's layout but not in derive/: {sorted(named - have)}"


def test_readme_links_to_its_own_sections_resolve():
    """Every ](#anchor) of the README names a heading (GitHub's slugs: lower case,
    punctuation dropped, spaces to hyphens)."""
    import re
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    body = re.sub(r"```.*?```", "", text, flags=re.S)
    slugs = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
             for h in re.findall(r"^#{1,4} (.+)$", body, re.M)}
    links = set(re.findall(r"\]\(#([^)]+)\)", text))
    assert links and not links - slugs, sorted(links - slugs)
