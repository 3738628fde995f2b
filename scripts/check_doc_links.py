#!/usr/bin/env python3
"""Every relative link in README.md and docs/**/*.md points at a file or folder of the repository.

Usage: scripts/check_doc_links.py [ROOT]   (ROOT: the repository, default: this script's parent)
Prints FILE:LINE: the link and what is missing, one per broken link; exit 1 if any, 0 if none,
2 if ROOT has no README.md. Links inside fenced code blocks and inline code are not links; web
addresses (scheme://, mailto:) and in-page anchors (#...) are not checked.
"""
import pathlib
import re
import sys

LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
INLINE_CODE = re.compile(r"`[^`]*`")


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
            path = target.split("#", 1)[0].split("?", 1)[0]
            resolved = (page.parent / path).resolve()
            if not resolved.exists():
                yield number, target, f"{resolved} does not exist"
            elif root.resolve() not in resolved.parents and resolved != root.resolve():
                yield number, target, "outside the repository (a clone does not have it)"


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    if not (root / "README.md").is_file():
        print(f"{root}: no README.md here: give the repository's root", file=sys.stderr)
        return 2
    bad = 0
    checked = 0
    for page in pages(root):
        for number, target, problem in broken_links(root, page):
            print(f"{page.relative_to(root)}:{number}: link '{target}': {problem}")
            bad += 1
        checked += 1
    print(f"{checked} pages checked, {bad} broken links", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
