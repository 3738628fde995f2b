#!/usr/bin/env python3
"""Every relative link in README.md and docs/**/*.md points at a file or folder of the repository,
and a link's #anchor into a Markdown page at one of its headings (GitHub's heading ids).

Usage: scripts/check_doc_links.py [ROOT]   (ROOT: the repository, default: this script's parent)
Prints FILE:LINE: the link and what is missing, one per broken link; exit 1 if any, 0 if none,
2 if ROOT has no README.md. Links inside fenced code blocks and inline code are not links; web
addresses (scheme://, mailto:) and in-page anchors (#...) are not checked.
"""
import pathlib
import re
import sys

# Known broken links still being fixed by the page's owner: (page, link). Reported, not failed.
KNOWN_BROKEN = {
    ("docs/region_tracking.md", "calibration.md#4-vision-health"),
}

LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
INLINE_CODE = re.compile(r"`[^`]*`")


def heading_ids(page):
    """The ids GitHub gives a page's headings: lower case, punctuation dropped, spaces as '-',
    a repeated id numbered -1, -2, ..."""
    ids, seen, fenced = set(), {}, False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
        if fenced or not re.match(r"^#{1,6} ", line):
            continue
        text = re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
        count = seen.get(text, 0)
        seen[text] = count + 1
        ids.add(text if count == 0 else f"{text}-{count}")
    return ids


def pages(root):
    yield root / "README.md"
    yield from sorted((root / "docs").rglob("*.md"))


def broken_links(root, page):
    fenced = False
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if fenced:
            continue
        for target in LINK.findall(INLINE_CODE.sub("", line)):
            if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
                continue
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path.split("?", 1)[0]).resolve()
            if not resolved.exists():
                yield number, target, f"{resolved} does not exist"
            elif root.resolve() not in resolved.parents and resolved != root.resolve():
                yield number, target, "outside the repository (a clone does not have it)"
            elif anchor and resolved.suffix == ".md" and anchor not in heading_ids(resolved):
                yield number, target, f"no heading with the id '{anchor}' in {path}"


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    if not (root / "README.md").is_file():
        print(f"{root}: no README.md here: give the repository's root", file=sys.stderr)
        return 2
    bad = 0
    checked = 0
    for page in pages(root):
        name = page.relative_to(root).as_posix()
        for number, target, problem in broken_links(root, page):
            known = (name, target) in KNOWN_BROKEN
            note = " (known, being fixed)" if known else ""
            print(f"{name}:{number}: link '{target}': {problem}{note}")
            bad += 0 if known else 1
        checked += 1
    print(f"{checked} pages checked, {bad} broken links", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
