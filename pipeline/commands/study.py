"""``pipeline study STUDY.yaml``: mode-truncation and design studies on Dask."""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.commands import add_links_arg
from pipeline.core.errors import ConfigError


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", type=Path, help="study YAML (see docs/studies.md)")
    parser.add_argument("--out", type=Path, default=Path("output"),
                        help="output root (default: output); the study writes <out>/<name>/")
    parser.add_argument("--workers", type=int, default=2,
                        help="processes of the local Dask cluster (default 2)")
    parser.add_argument("--scheduler", default=None,
                        help="address of an existing Dask scheduler, e.g. tcp://host:8786")
    add_links_arg(parser)
    parser.add_argument("--worker-timeout", type=float, default=None, metavar="SECONDS",
                        help="end the cases left as 'lost' once the cluster has had no worker "
                             "for this long (default 120)")


def run(args: argparse.Namespace) -> int:
    from pipeline.invariants.cache import default_links_dir
    from pipeline.study.engine import WORKER_TIMEOUT, run_study
    from pipeline.study.spec import mode_text

    timeout = WORKER_TIMEOUT if args.worker_timeout is None else args.worker_timeout
    if not timeout > 0:
        raise ConfigError(f"--worker-timeout: expected seconds > 0, got {args.worker_timeout}")
    res = run_study(args.study, out_root=args.out, workers=max(1, args.workers),
                    scheduler=args.scheduler,
                    cache_dir=args.links if args.links is not None else default_links_dir(),
                    worker_timeout=timeout)
    print(f"{res.folder.name}: {len(res.rows)} cases ({res.ran} run now, "
          f"{len(res.rows) - res.ran} from the table) -> {res.folder}")
    for r in res.rows:
        outs = ", ".join(f"{k[4:]}={v:.6g}" for k, v in r.items()
                         if k.startswith("out:") and isinstance(v, float))
        print(f"  {r['case']:<40} {r['status']:<8} {r['seconds']:7.2f} s  {outs}")
    for link, rec in res.recommendation.items():
        if rec["recommended"] is None:
            print(f"  {link}: no recommendation ({rec.get('why', 'no case finished')})")
            continue
        print(f"  {link}: {mode_text(rec['recommended'])} recommended (within "
              f"{100 * rec['tolerance']:g} % of {mode_text(rec['reference'])})")
        for k, ev in rec["evidence"].items():
            worst = max(ev.values()) if ev else float("nan")
            print(f"    {mode_text(k)}: largest relative RMS difference "
                  f"{100 * worst:.3g} %")
    return 1 if any(r["status"] in ("error", "lost") for r in res.rows) else 0
