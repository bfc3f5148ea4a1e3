"""The README and the documents in docs/ as a tested contract: every command a document shows after
a `$ ` prompt runs as written, in order, in one temporary folder of its own (the README in one,
each docs/*.md in another, so every document's sessions stand alone), and every output line it
shows is printed.

Lines are compared exactly, with two stated allowances: `...` in a shown output stands for any
number of omitted lines, and run-time measurements (seconds, calls or cycles per second) are
compared as numbers of any value, since they depend on the machine.

Every relative link of these documents must name a file of the repository, and a `#anchor` a
heading of that file (a quick test, no commands run).
"""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))
TIMING = re.compile(r"\d[\d,]*(?:\.\d+)?(?= (?:s\b|cycles/s|calls/s|M calls/s|MiB))")


def shown_sessions(text: str) -> list[tuple[str, list[str]]]:
    """(command, shown output lines) for every `$ ` line of every fenced block, in order."""
    sessions = []
    for block in re.findall(r"```\n(.*?)```", text, flags=re.S):
        lines = block.splitlines()
        if not lines or not lines[0].startswith("$ "):
            continue
        k = 0
        while k < len(lines):
            command = lines[k][2:]
            while command.endswith("\\"):
                k += 1
                command = command[:-1] + " " + lines[k].strip()
            k += 1
            output = []
            while k < len(lines) and not lines[k].startswith("$ "):
                output.append(lines[k])
                k += 1
            sessions.append((command, output))
    return sessions


def _masked(line: str) -> str:
    return TIMING.sub("#", line.rstrip())


def missing_lines(shown: list[str], printed: list[str]) -> list[str]:
    """Shown lines not printed in that order (`...` skips any number of printed lines)."""
    printed = [_masked(p) for p in printed]
    position, missing, skipping = 0, [], False
    for line in shown:
        if line.strip() == "...":
            skipping = True
            continue
        want = _masked(line)
        if skipping:
            found = next((j for j in range(position, len(printed)) if printed[j] == want), None)
        else:
            found = position if position < len(printed) and printed[position] == want else None
        if found is None:
            missing.append(line)
            continue
        position, skipping = found + 1, False
    return missing


def _run_sessions(text: str, folder: Path) -> list[str]:
    """Run every `$ ` command of `text` in order in `folder`; the failures, one text each."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "SOURCE_DATE_EPOCH": "1767225600"}
    failures = []
    for command, shown in shown_sessions(text):
        result = subprocess.run(["bash", "-c", command], cwd=folder, env=env, capture_output=True, text=True,
                                stdin=subprocess.DEVNULL)
        if result.returncode not in (0, 1):  # 1: verify and diff report a difference, as the README shows
            failures.append(f"$ {command}\n  exit {result.returncode}: {result.stderr.strip()}")
            continue
        missing = missing_lines(shown, result.stdout.splitlines())
        if missing:
            failures.append(f"$ {command}\n  not printed:\n    " + "\n    ".join(missing)
                            + "\n  printed:\n    " + "\n    ".join(result.stdout.splitlines()[:40]))
    return failures


def _without_code(text: str) -> str:
    """The text without fenced blocks and inline code spans (a `#` or `[x](y)` there is not markdown)."""
    text = re.sub(r"^```.*?^```[ \t]*$", "", text, flags=re.S | re.M)
    return re.sub(r"`[^`\n]*`", "", text)


def heading_anchors(text: str) -> set[str]:
    """The `#anchor` of every heading, as GitHub makes them (lower case, punctuation dropped,
    spaces to hyphens, `-1`, `-2` ... for repeats)."""
    anchors: set[str] = set()
    for heading in re.findall(r"^#{1,6}[ \t]+(.+?)[ \t]*#*[ \t]*$", re.sub(r"^```.*?^```[ \t]*$", "", text,
                                                                        flags=re.S | re.M), flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        anchor, k = slug, 0
        while anchor in anchors:
            k += 1
            anchor = f"{slug}-{k}"
        anchors.add(anchor)
    return anchors


def broken_links(path: Path, root: Path = ROOT) -> list[str]:
    """Relative links of a markdown file whose file (inside `root`), or whose `#anchor` in that file,
    does not exist."""
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", _without_code(path.read_text())):
        if re.match(r"[a-z][a-z0-9+.-]*:", target, flags=re.I):  # https:, mailto: ...: not a file
            continue
        name, _, anchor = target.partition("#")
        linked = (path.parent / name).resolve() if name else path
        if not linked.exists() or root.resolve() not in (linked, *linked.parents):
            broken.append(f"{path.name}: {target}: no such file in the repository")
        elif anchor and linked.suffix == ".md" and anchor not in heading_anchors(linked.read_text()):
            broken.append(f"{path.name}: {target}: no heading #{anchor} in {linked.name}")
    return broken


@pytest.mark.parametrize("path", [README, *DOCS], ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_names_an_existing_file_and_heading(path):
    assert not broken_links(path), "\n".join(broken_links(path))


def test_the_link_check_sees_a_broken_link(tmp_path):
    (tmp_path / "a.md").write_text("# Title: one\n\n[ok](a.md#title-one) [file](b.md) [anchor](#nowhere) "
                                   "[out](../x.md) `[code](c.md)` [web](https://example.com/x.md)\n"
                                   "```\n# not a heading\n[code](d.md)\n```\n")
    assert broken_links(tmp_path / "a.md", root=tmp_path) == [
        "a.md: b.md: no such file in the repository", "a.md: #nowhere: no heading #nowhere in a.md",
        "a.md: ../x.md: no such file in the repository"]
    assert heading_anchors("# What `generate` proves\n## A (B)\n## A (B)\n```\n# x\n```\n") == {
        "what-generate-proves", "a-b", "a-b-1"}


def test_the_parser_of_the_readme_sees_the_walkthrough():
    commands = [c for c, _ in shown_sessions(README.read_text())]
    assert commands[0].startswith("thermoplc twin --hours 48 --seed 3")
    assert any(c.startswith("sed ") and "Edited.scl" in c for c in commands)
    assert missing_lines(["a", "...", "c"], ["a", "b", "c"]) == []
    assert missing_lines(["a", "c"], ["a", "b", "c"]) == ["c"]
    assert missing_lines(["replay: 0.01 s, 9 cycles/s"], ["replay: 2.50 s, 1,234 cycles/s"]) == []


@pytest.mark.slow  # the walkthrough fits, generates, verifies and diagnoses: a few minutes
def test_every_command_of_the_readme_prints_what_the_readme_shows(tmp_path):
    failures = _run_sessions(README.read_text(), tmp_path)
    assert not failures, "\n".join(failures)


DOCS_WITH_COMMANDS = [path for path in DOCS if shown_sessions(path.read_text())]


def test_the_parser_sees_the_commands_of_the_docs():
    assert ROOT / "docs" / "models.md" in DOCS_WITH_COMMANDS  # the demo
    assert any(c.startswith("thermoplc demo") for c, _ in shown_sessions((ROOT / "docs" / "models.md").read_text()))


@pytest.mark.slow  # the demo fits and verifies on the bundled recording
@pytest.mark.parametrize("path", DOCS_WITH_COMMANDS, ids=lambda p: p.name)
def test_every_command_of_a_doc_prints_what_the_doc_shows(path, tmp_path):
    failures = _run_sessions(path.read_text(), tmp_path)
    assert not failures, f"{path.name}:\n" + "\n".join(failures)
