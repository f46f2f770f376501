#!/usr/bin/python3
"""Include-layering check: every #include of our own code must follow the folder DAG.

The rules are the table between the `layering-table` markers in docs/architecture.md
("Include layering (checked)"); this script holds no copy of them. For every source file
under a folder named in the table (top-level folder of its path), each `#include "x/..."`
(and `#include <x/...>` when x/... exists in the tree) whose first component x is another
folder of the table must be one the file's folder may include. `#include "name.hpp"` and
`"../..."` are resolved next to the file.

Known violations (still to fix) are listed in an allow-list file, one a line:
    <file> -> <included path>    # optional comment
They are reported as known and do not fail the check; entries that no longer occur are
reported as stale (remove them).

Usage: check-layering.py [--root DIR] [--rules FILE] [--known FILE]
  --root   the tree to check (default: this repository)
  --rules  the markdown file with the table (default: docs/architecture.md of this repository)
  --known  the allow-list (default: tests/lint/layering_known.txt of this repository when
           --root is this repository, none otherwise)
Exit status: 0 when every include is allowed or known, 1 on a violation, 2 on a usage or
rules error.
"""
import argparse
import os
import re
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE_EXT = (".hpp", ".h", ".hh", ".ipp", ".cpp", ".cc", ".cxx", ".c")
SKIP_DIRS = {".git", "node_modules"}
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def read_rules(path):
    """{folder: set(folders it may include)} from the marked markdown table."""
    try:
        text = open(path, encoding="utf-8").read()
    except OSError as e:
        sys.exit(f"check-layering: cannot read the rules: {e}")
    m = re.search(r"<!-- layering-table:begin -->(.*?)<!-- layering-table:end -->", text, re.S)
    if not m:
        print(f"check-layering: {path}: no layering-table markers", file=sys.stderr)
        sys.exit(2)
    rules = {}
    for line in m.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 2 or not cells[0].startswith("`"):
            continue  # header, separator or prose
        folder = cells[0].strip("`")
        allowed = set(re.findall(r"`([^`]+)`", cells[1]))
        rules[folder] = allowed
    if not rules:
        print(f"check-layering: {path}: the layering table has no rows", file=sys.stderr)
        sys.exit(2)
    for folder, allowed in rules.items():
        unknown = allowed - set(rules)
        if unknown:
            print(f"check-layering: {path}: {folder} may include unknown folder(s) {sorted(unknown)}", file=sys.stderr)
            sys.exit(2)
    return rules


def read_known(path):
    known = set()
    if not path:
        return known
    try:
        lines = open(path, encoding="utf-8").read().splitlines()
    except OSError as e:
        print(f"check-layering: cannot read the allow-list: {e}", file=sys.stderr)
        sys.exit(2)
    for n, line in enumerate(lines, 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        if "->" not in line:
            print(f"check-layering: {path}:{n}: expected '<file> -> <included path>'", file=sys.stderr)
            sys.exit(2)
        src, inc = (p.strip() for p in line.split("->", 1))
        known.add((src, inc))
    return known


def sources(root, folders):
    for folder in sorted(folders):
        top = os.path.join(root, folder)
        if not os.path.isdir(top):
            continue
        for dirpath, dirnames, filenames in os.walk(top):
            dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS)
            for name in sorted(filenames):
                if name.endswith(SOURCE_EXT):
                    yield os.path.relpath(os.path.join(dirpath, name), root)


def target_folder(root, rel_file, quote, inc, folders):
    """The folder of the table an include refers to, or None when it is not our code."""
    first = inc.split("/", 1)[0]
    if quote == '"' and (first in (".", "..") or "/" not in inc):
        resolved = os.path.normpath(os.path.join(os.path.dirname(rel_file), inc))
        if os.path.exists(os.path.join(root, resolved)) or "/" not in inc:
            top = resolved.split(os.sep, 1)[0]
            return top if top in folders else None
    if first not in folders:
        return None
    if quote == "<" and not os.path.exists(os.path.join(root, inc)):
        return None
    return first


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", default=REPO)
    ap.add_argument("--rules", default=os.path.join(REPO, "docs", "architecture.md"))
    ap.add_argument("--known", default=None)
    args = ap.parse_args()
    root = os.path.abspath(args.root)
    known_path = args.known
    if known_path is None and root == REPO:
        known_path = os.path.join(REPO, "tests", "lint", "layering_known.txt")
    rules = read_rules(args.rules)
    known = read_known(known_path)

    violations, seen_known = [], set()
    checked = 0
    for rel in sources(root, rules):
        folder = rel.split(os.sep, 1)[0]
        try:
            lines = open(os.path.join(root, rel), encoding="utf-8", errors="replace").read().splitlines()
        except OSError:
            continue
        checked += 1
        for n, line in enumerate(lines, 1):
            m = INCLUDE_RE.match(line)
            if not m:
                continue
            quote, inc = m.group(1), m.group(2)
            target = target_folder(root, rel, quote, inc, rules)
            if target is None or target == folder or target in rules[folder]:
                continue
            key = (rel.replace(os.sep, "/"), inc)
            if key in known:
                seen_known.add(key)
                continue
            may = ", ".join(sorted(rules[folder])) or "nothing of ours"
            violations.append(f'{key[0]}:{n}: {folder}/ may not include {target}/ ("{inc}"); '
                              f"{folder}/ may include: {may} (rule: {os.path.relpath(args.rules, root) if args.rules.startswith(root) else args.rules})")
    for v in violations:
        print(v)
    for src, inc in sorted(seen_known):
        print(f"known: {src} -> {inc} ({os.path.basename(known_path)})")
    for src, inc in sorted(known - seen_known):
        print(f"stale: {src} -> {inc} no longer occurs: remove it from {known_path}")
    status = "FAILED" if violations else "ok"
    print(f"check-layering: {status}: {checked} files, {len(violations)} violation(s), {len(seen_known)} known")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
