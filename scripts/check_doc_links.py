#!/usr/bin/env python3
"""The docs' links hold: every relative link in README.md and docs/**/*.md points at a file or
folder of the repository, a link's #anchor into a Markdown page names one of its headings
(GitHub's heading ids), and every dated log (docs/log/*.md) is linked from a page outside
docs/log (the reference links its history).

Usage: scripts/check_doc_links.py [ROOT]   (ROOT: the repository, default: this script's parent)
Prints FILE:LINE: the link and what is wrong, one line per problem; exit 1 if any, 0 if none,
2 if ROOT has no README.md. Links inside fenced code blocks and inline code are not links; web
addresses (scheme:...) and in-page anchors (#...) are not checked.
"""
import pathlib
import re
import sys

# Known broken links still being fixed by the page's owner: (page, link). Reported, not failed.
KNOWN_BROKEN: set[tuple[str, str]] = set()

LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
INLINE_CODE = re.compile(r"`[^`]*`")
SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def pages(root):
    yield root / "README.md"
    yield from sorted((root / "docs").rglob("*.md"))


def link_targets(page):
    """(line number, target) of every link outside code."""
    fenced = False
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if not fenced:
            for target in LINK.findall(INLINE_CODE.sub("", line)):
                yield number, target


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


def check_page(root, page, linked):
    """Yields (line, target, problem) for each broken link; adds every resolved file to linked."""
    for number, target in link_targets(page):
        if SCHEME.match(target) or target.startswith("#"):
            continue
        path, _, anchor = target.partition("#")
        resolved = (page.parent / path.split("?", 1)[0]).resolve()
        if not resolved.exists():
            yield number, target, f"{resolved} does not exist"
        elif root not in resolved.parents and resolved != root:
            yield number, target, "outside the repository (a clone does not have it)"
        elif anchor and resolved.suffix == ".md" and anchor not in heading_ids(resolved):
            yield number, target, f"no heading with the id '{anchor}' in {path}"
        else:
            linked.add(resolved)


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    root = root.resolve()
    if not (root / "README.md").is_file():
        print(f"{root}: no README.md here: give the repository's root", file=sys.stderr)
        return 2
    log_dir = root / "docs" / "log"
    bad, checked, linked_from_reference = 0, 0, set()
    for page in pages(root):
        name = page.relative_to(root).as_posix()
        linked = set()
        for number, target, problem in check_page(root, page, linked):
            known = (name, target) in KNOWN_BROKEN
            note = " (known, being fixed)" if known else ""
            print(f"{name}:{number}: link '{target}': {problem}{note}")
            bad += 0 if known else 1
        if log_dir not in page.parents:
            linked_from_reference |= linked
        checked += 1
    for log in sorted(log_dir.glob("*.md")) if log_dir.is_dir() else []:
        if log.name != "README.md" and log not in linked_from_reference:
            print(f"{log.relative_to(root).as_posix()}: no page outside docs/log links to this log")
            bad += 1
    print(f"{checked} pages checked, {bad} broken links", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
