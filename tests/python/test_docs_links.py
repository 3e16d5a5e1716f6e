"""Every relative link of the repository's Markdown files resolves inside the repository: the
file exists and, for a link into a .md file with #anchor, that file has a heading (GitHub's
anchor of it) or an <a name/id> with that anchor. Links with a scheme (https:, mailto:) and
links inside fenced code blocks are not checked, nor the vendored crates' own files
(core/rust/vendor: as published, with links into their own repositories)."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def markdown_files():
    out = subprocess.run(["git", "-C", str(ROOT), "ls-files", "*.md"], check=True,
                         capture_output=True, text=True).stdout.split()
    return [ROOT / f for f in out if not f.startswith("core/rust/vendor/")]


def without_code(text):
    return re.sub(r"```.*?```", "", text, flags=re.S)


def slug(heading):
    """GitHub's anchor of a heading: markup dropped, lower case, punctuation dropped, spaces -."""
    h = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip())
    h = re.sub(r"[`*_]", "", h).lower()
    return re.sub(r"[^\w\- ]", "", h).replace(" ", "-")


def anchors(path):
    found, seen = set(), {}
    for line in without_code(path.read_text(errors="replace")).split("\n"):
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            s = slug(m.group(1))
            n = seen.get(s, 0)
            seen[s] = n + 1
            found.add(s if n == 0 else f"{s}-{n}")
        found.update(re.findall(r'<a (?:name|id)="([^"]+)"', line))
    return found


def broken_links():
    bad, cache = [], {}
    for md in markdown_files():
        text = without_code(md.read_text(errors="replace"))
        for target in re.findall(r"\[[^\]]*\]\(([^)\s]+)\)", text):
            if re.match(r"^[a-z]+:", target):
                continue
            path, _, frag = target.partition("#")
            dest = (md.parent / path).resolve() if path else md.resolve()
            rel = md.relative_to(ROOT)
            if not dest.exists():
                bad.append(f"{rel}: {target} (no such file)")
            elif frag and dest.suffix == ".md":
                if dest not in cache:
                    cache[dest] = anchors(dest)
                if frag not in cache[dest]:
                    bad.append(f"{rel}: {target} (no such heading)")
    return bad


def test_relative_links_resolve():
    assert broken_links() == []


def test_a_broken_link_is_found(tmp_path, monkeypatch):
    # The check itself: a link to a missing file and one to a missing heading are reported.
    doc = tmp_path / "a.md"
    doc.write_text("# Title\n[ok](#title) [gone](missing.md) [nohead](#other)\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    monkeypatch.setattr(sys.modules[__name__], "markdown_files", lambda: [doc])
    assert broken_links() == ["a.md: missing.md (no such file)", "a.md: #other (no such heading)"]
