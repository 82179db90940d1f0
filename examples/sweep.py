#!/usr/bin/env python3
"""A parameter or cohort sweep of Lamina scenes over dask.distributed, results in one CSV.

Every combination of masks x E x nu x locality x penetration depth runs the default scene (the
physical liver held at its back, one 0.4 N poke for 1 s, run until it rests) as `lamina run`
would, one task each. A local cluster by default (one single-threaded worker per core); give
--scheduler tcp://HOST:8786 to run the same script on a cluster whose workers can import
lamina and read the masks at the same paths.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/sweep.py \
        --young-modulus-kpa 3 6 12 --masks phantom tests/data/liver_totalseg_example_3mm.nii.gz
"""
import argparse
import csv
import itertools
import os
import socket
import sys
import time

FIELDS = ["mask", "young_modulus_kpa", "poisson_ratio", "locality", "penetration_depth",
          "converged", "steps", "time_s", "peak_displacement_mm", "peak_abs_volume_change_pct",
          "max_reaction_mn", "max_displacement_mm", "recoveries", "wall_s", "worker", "error"]


def run_case(case, until_s):
    """One scene run on a worker; an error is a row with its message, not a lost sweep."""
    import lamina  # imported on the worker

    scene = {
        "model": {"input": case["mask"]},
        "material": {"young_modulus_kpa": case["young_modulus_kpa"],
                     "poisson_ratio": case["poisson_ratio"]},
        "solver": {"locality": case["locality"], "penetration_depth": case["penetration_depth"]},
    }
    row = dict(case, worker=socket.gethostname() + ":" + str(os.getpid()), error="")
    start = time.perf_counter()
    try:
        result = lamina.run_scene(scene, until_s=until_s)
        row.update({k: result[k] for k in FIELDS if k in result})
    except lamina.Error as e:
        row["error"] = str(e)
    row["wall_s"] = round(time.perf_counter() - start, 3)
    return row


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--masks", nargs="+", default=["phantom"],
                   help="masks (NIfTI, NRRD, MetaImage, DICOM folder) or 'phantom'")
    p.add_argument("--young-modulus-kpa", nargs="+", type=float, default=[6.0], help="E, kPa")
    p.add_argument("--poisson-ratio", nargs="+", type=float, default=[0.45], help="nu")
    p.add_argument("--locality", nargs="+", type=int, default=[4], help="N, rings")
    p.add_argument("--penetration-depth", nargs="+", type=int, default=[4], help="P, crossings")
    p.add_argument("--until-s", type=float, default=float("inf"),
                   help="stop each run at this simulated time (default: when it rests)")
    p.add_argument("--scheduler", default=None,
                   help="a dask scheduler's address (default: a local cluster)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="local cluster: worker processes (default: one per core)")
    p.add_argument("-o", "--output", default="sweep.csv", help="CSV to write (default sweep.csv)")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    for m in args.masks:
        if m != "phantom" and not os.path.exists(m):
            print(f"sweep: {m}: no such mask", file=sys.stderr)
            return 2
    cases = [dict(zip(["mask", "young_modulus_kpa", "poisson_ratio", "locality",
                       "penetration_depth"], values))
             for values in itertools.product([os.path.abspath(m) if m != "phantom" else m
                                              for m in args.masks],
                                             args.young_modulus_kpa, args.poisson_ratio,
                                             args.locality, args.penetration_depth)]

    from dask.distributed import Client, LocalCluster, as_completed

    if args.scheduler:
        client = Client(args.scheduler)
        cluster = None
    else:
        # One single-threaded worker per core: a step's OpenMP threads would only compete.
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    print(f"sweep: {len(cases)} runs on {len(client.scheduler_info()['workers'])} workers "
          f"({args.scheduler or 'local cluster'})", file=sys.stderr)

    rows = []
    futures = [client.submit(run_case, c, args.until_s, pure=False) for c in cases]
    for k, future in enumerate(as_completed(futures), 1):
        row = future.result()
        rows.append(row)
        what = row["error"] or (f"peak {row['peak_displacement_mm']:.2f} mm in "
                                f"{row['wall_s']:.1f} s")
        print(f"sweep: {k}/{len(cases)} {os.path.basename(row['mask'])} "
              f"E={row['young_modulus_kpa']:g} nu={row['poisson_ratio']:g} "
              f"N={row['locality']} P={row['penetration_depth']}: {what}", file=sys.stderr)
    client.close()
    if cluster is not None:
        cluster.close()

    # In the order of the cases, written whole or not at all.
    order = {tuple(c.values()): i for i, c in enumerate(cases)}
    rows.sort(key=lambda r: order[tuple(r[k] for k in cases[0])])
    tmp = args.output + ".tmp"
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, args.output)
    failed = sum(1 for r in rows if r["error"])
    print(f"sweep: wrote {args.output} ({len(rows)} rows, {failed} failed)", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
