"""Reuse a reduced-link artifact while its inputs are unchanged; the one link cache.

A stored artifact is reused only if it loads intact (format, version and
content digest check out) *and* records the same input hash; otherwise it is
rebuilt and replaced atomically. A corrupted file is never used.

Every command keeps its reduced links in one content-addressed cache,
``<cache>/<name>-<hash>/<name>.npz`` (:func:`artifact_path`): ``pipeline reduce``,
``validate --build``, ``run`` and ``study`` of the same spec share the artifact, whatever
their ``--out``. The cache is ``$FLEXMECH_LINKS`` if set, else ``output/links`` under the
current folder (:func:`default_links_dir`); :func:`cache_entries` and :func:`remove_entries`
list and clear it (``pipeline cache``).
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pipeline.core.atomic import folder_bytes
from pipeline.core.errors import ArtifactError
from pipeline.invariants.reduced_link import ReducedLink
from pipeline.invariants.store import load_reduced_link, read_header, save_reduced_link

logger = logging.getLogger(__name__)

#: the environment variable naming the shared link cache
LINKS_ENV = "FLEXMECH_LINKS"
#: a cache entry's folder: the link's name and the first 12 hex digits of its input hash
_ENTRY = re.compile(r"^(?P<name>[A-Za-z_][A-Za-z0-9_\-]*)-(?P<hash>[0-9a-f]{12})$")


def default_links_dir() -> Path:
    """The shared reduced-link cache: ``$FLEXMECH_LINKS``, else ``output/links``."""
    return Path(os.environ.get(LINKS_ENV) or Path("output") / "links")


def artifact_folder(name: str, digest: str) -> str:
    """The folder of the link cache holding the artifact of link spec ``name`` built from
    inputs of hash ``digest`` (content-addressed: one folder per distinct input)."""
    return f"{name}-{digest[:12]}"


def artifact_path(cache_dir: str | Path, name: str, digest: str) -> Path:
    """``<cache_dir>/<name>-<digest[:12]>/<name>.npz``."""
    return Path(cache_dir) / artifact_folder(name, digest) / f"{name}.npz"


@dataclass(frozen=True)
class CacheEntry:
    """One artifact of the cache: folder, link name, input hash (12 digits), bytes, seconds
    since the epoch of its last write, and the spec file it was reduced from (if known)."""

    folder: Path
    name: str
    digest: str
    size: int
    modified: float
    spec: str | None


def cache_entries(cache_dir: str | Path) -> list[CacheEntry]:
    """The cache's artifacts, newest first (folders that are not entries are left alone)."""
    cache_dir = Path(cache_dir)
    out = []
    for folder in sorted(cache_dir.iterdir()) if cache_dir.is_dir() else ():
        m = _ENTRY.match(folder.name)
        npz = folder / f"{m.group('name')}.npz" if m else None
        if npz is None or not npz.is_file() or folder.is_symlink():
            continue
        size = folder_bytes(folder)
        try:
            spec = read_header(npz).get("meta", {}).get("spec_file")
        except ArtifactError:
            spec = "(unreadable: rebuilt on next use)"
        out.append(CacheEntry(folder, m.group("name"), m.group("hash"), size,
                              npz.stat().st_mtime, spec))
    return sorted(out, key=lambda e: -e.modified)


def remove_entries(entries: list[CacheEntry]) -> int:
    """Delete the given entries' folders; the bytes freed."""
    freed = 0
    for e in entries:
        if _ENTRY.match(e.folder.name) and not e.folder.is_symlink():
            shutil.rmtree(e.folder, ignore_errors=True)
            freed += e.size
    return freed


def older_than(entries: list[CacheEntry], days: float) -> list[CacheEntry]:
    """The entries last written more than ``days`` ago."""
    limit = time.time() - days * 86400.0
    return [e for e in entries if e.modified < limit]


def cached_reduced_link(path: str | Path, input_hash: str,
                        build: Callable[[], ReducedLink]) -> tuple[ReducedLink, str]:
    """Load ``path`` if it is intact and built from ``input_hash``, else ``build()`` it.

    Returns
    -------
    (link, status) with status "hit", "miss" (absent or stale) or "corrupt"
    (unreadable, rebuilt).
    """
    path = Path(path)
    status = "miss"
    if path.exists():
        try:
            link = load_reduced_link(path)
        except ArtifactError as exc:
            logger.warning("%s; rebuilding", exc)
            status = "corrupt"
        else:
            if link.meta.get("input_hash") == input_hash:
                return link, "hit"
            logger.info("%s: inputs changed; rebuilding", path)
    link = build()
    save_reduced_link(link, path)
    return link, status
