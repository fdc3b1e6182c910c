"""One-off (2026-11-29): result files written before benchmarks/_common.portable carry the absolute paths of the
checkouts that wrote them (/work/main, fresh clones, worktrees). Rewrite those repository-relative, ../shared for the
data beside it; scratch folders under /tmp that were not checkouts are left as written (they name where that run
kept its outputs). Run from the repository root: python experiments/2026-11-29_portable_paths/rewrite.py"""

from __future__ import annotations

import re
from pathlib import Path

CHECKOUTS = re.compile(r"(?:/work/(?:main|fresh\w*|wt_\w+)|/tmp/(?:s10/gq/repo|\w+/repo|fc|fresh))(?![\w.-])")
SHARED = re.compile(r"/work/shared(?![\w.-])")


def rewrite(text: str) -> str:
    text = SHARED.sub("../shared", text)
    text = CHECKOUTS.sub(lambda m: "\0", text)  # a checkout root: the repository itself
    return text.replace("\0/", "").replace("\0", ".")


def main() -> None:
    changed = 0
    for root in (Path("benchmarks/results"), Path("experiments")):
        for path in sorted(root.rglob("*")):
            if path.suffix not in {".md", ".json", ".sh", ".csv", ".txt"} or not path.is_file():
                continue
            before = path.read_text()
            after = rewrite(before)
            if after != before:
                path.write_text(after)
                changed += 1
    print(f"{changed} files rewritten")


if __name__ == "__main__":
    main()
