"""MkDocs hooks (mkdocs.yml ``hooks:``): the site is built from the repository as it is.

* The README is the home page: it is served as ``index.md`` from the file
  itself, not from a copy that could drift.
* Pages are written for reading on GitHub, with links relative to where their
  file lies in the repository (the README links ``docs/model.md``, the
  benchmark page ``../benchmarks/results/...``). Each relative link is resolved
  from its page's file in the repository: a target inside ``docs/`` becomes the
  path of that page in the site, and a repository file outside ``docs/``
  (``LICENSE``, benchmark results) is published under ``repo/`` with the same
  path. MkDocs then checks every link and anchor (``mkdocs build --strict``
  fails on a broken one), so a link that works here works on GitHub too.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, InclusionLevel

ROOT = Path(__file__).resolve().parents[1]
#: Where repository files outside docs/ are published in the site.
REPO_PREFIX = "repo/"
# [text](target) and ![alt](target); the target ends at whitespace or ")"
LINK = re.compile(r"(!?\[[^\]]*\]\()([^)\s]+)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.M | re.S)


def _source(file) -> str:
    """The repository path of a site file (README.md for the home page)."""
    if file.src_uri == "index.md":
        return "README.md"
    if file.src_uri.startswith(REPO_PREFIX):
        return file.src_uri[len(REPO_PREFIX):]
    return "docs/" + file.src_uri


def _is_relative(target: str) -> bool:
    return not (target.startswith(("#", "/", "mailto:")) or re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", target))


def _site_path(repo_path: str) -> str:
    return repo_path[len("docs/"):] if repo_path.startswith("docs/") else REPO_PREFIX + repo_path


def _links(markdown: str, source: str):
    """(match, repository path of the target) of each relative link outside code blocks."""
    spans = [m.span() for m in FENCE.finditer(markdown)]
    for m in LINK.finditer(markdown):
        if any(a <= m.start() < b for a, b in spans):
            continue
        target = m.group(2)
        if not _is_relative(target):
            continue
        path = target.split("#", 1)[0]
        if path:
            yield m, posixpath.normpath(posixpath.join(posixpath.dirname(source), path))


def on_files(files, config):
    """Serve README.md as index.md, and publish the repository files the pages link to."""
    files.append(File.generated(config, "index.md", abs_src_path=str(ROOT / "README.md")))
    seen, todo = set(), [f for f in files if f.src_uri.endswith(".md")]
    while todo:
        page = todo.pop()
        for _, repo_path in _links(Path(page.abs_src_path).read_text(encoding="utf-8"), _source(page)):
            site_path = _site_path(repo_path)
            if repo_path.startswith("docs/") or site_path in seen or not (ROOT / repo_path).is_file():
                continue  # a missing file is left for MkDocs to report
            seen.add(site_path)
            new = File.generated(config, site_path, abs_src_path=str(ROOT / repo_path),
                                 inclusion=InclusionLevel.NOT_IN_NAV)
            files.append(new)
            if site_path.endswith(".md"):
                todo.append(new)
    return files


def on_page_markdown(markdown, page, config, files):
    """Rewrite each relative link from its file's place in the repository to its place in the site."""
    source = _source(page.file)
    here = posixpath.dirname(page.file.src_uri)
    out, last = [], 0
    for m, repo_path in _links(markdown, source):
        target = m.group(2)
        anchor = target[len(target.split("#", 1)[0]):]
        new = posixpath.relpath(_site_path(repo_path), here or ".") + anchor
        out.append(markdown[last:m.start(2)] + new)
        last = m.end(2)
    out.append(markdown[last:])
    return "".join(out)
