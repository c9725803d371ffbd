"""``pipeline cache``: what the shared reduced-link cache holds, and clearing it."""

from __future__ import annotations

import argparse
import time

from pipeline.commands import add_links_arg


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", nargs="?", choices=("list", "clear"), default="list",
                        help="list the artifacts (default) or delete them")
    add_links_arg(parser)
    parser.add_argument("--name", default=None,
                        help="only the artifacts of this link spec name")
    parser.add_argument("--older-than", type=float, default=None, metavar="DAYS",
                        help="only the artifacts last written more than DAYS ago")


def run(args: argparse.Namespace) -> int:
    from pipeline.core.errors import ConfigError
    from pipeline.invariants.cache import (
        cache_entries,
        default_links_dir,
        older_than,
        remove_entries,
    )

    links = args.links if args.links is not None else default_links_dir()
    if args.older_than is not None and not args.older_than >= 0:
        raise ConfigError(f"--older-than: expected days >= 0, got {args.older_than}")
    entries = cache_entries(links)
    if args.name is not None:
        entries = [e for e in entries if e.name == args.name]
    if args.older_than is not None:
        entries = older_than(entries, args.older_than)
    if args.action == "clear":
        freed = remove_entries(entries)
        print(f"{links}: removed {len(entries)} reduced links, {freed / 2**20:.1f} MiB")
        return 0
    total = sum(e.size for e in entries)
    print(f"{links}: {len(entries)} reduced links, {total / 2**20:.1f} MiB")
    for e in entries:
        when = time.strftime("%Y-%m-%d %H:%M", time.localtime(e.modified))
        print(f"  {e.name:<24} {e.digest}  {e.size / 2**20:8.1f} MiB  {when}  "
              f"{e.spec or ''}")
    return 0
