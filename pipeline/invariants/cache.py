"""Reuse a reduced-link artifact while its inputs are unchanged.

A stored artifact is reused only if it loads intact (format, version and
content digest check out) *and* records the same input hash; otherwise it is
rebuilt and replaced atomically. A corrupted file is never used.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

from pipeline.core.errors import ArtifactError
from pipeline.invariants.reduced_link import ReducedLink
from pipeline.invariants.store import load_reduced_link, save_reduced_link

logger = logging.getLogger(__name__)


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
