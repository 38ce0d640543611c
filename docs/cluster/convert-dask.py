"""Converts a volume to a multiscale OME-Zarr image across a Dask cluster: the plan here, the
parts on the cluster's workers (each a `voxscope.convert.run_part`), `finalize` here again.

    python convert-dask.py IN OUT.ome.zarr PARTS [--scheduler ADDRESS] [OPTION=VALUE ...]

OPTIONs are `voxscope convert`'s, as typed on its command line (`format=0.5 chunk=64
raw=4096x4096x1064:i16`). Without `--scheduler`, a LocalCluster of PARTS worker processes of
one thread each runs the parts. The workers must reach OUT at the same path (a shared file
system) and IN too; each needs the `voxscope` Python module.
"""

import argparse
import time

from dask.distributed import Client, LocalCluster

import voxscope


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("parts", type=int)
    parser.add_argument("--scheduler", help="a Dask scheduler's address (tcp://HOST:8786)")
    parser.add_argument("options", nargs="*", metavar="OPTION=VALUE")
    args = parser.parse_args()
    options = dict(option.split("=", 1) for option in args.options)

    started = time.time()
    plan = voxscope.convert.plan(args.input, args.output, parts=args.parts, **options)
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        cluster = LocalCluster(n_workers=args.parts, threads_per_worker=1, processes=True)
        client = Client(cluster)
    with client:
        # pure=False: a part is an action on the shared folder, not a value to cache.
        futures = client.map(voxscope.convert.run_part, [plan] * args.parts,
                             range(args.parts), pure=False)
        for figures in client.gather(futures):
            print(f"part {figures['part']}/{figures['parts']}: {figures['objects']} objects, "
                  f"{figures['bytes_in'] / 1e6:.1f} MB in, {figures['seconds']:.2f} s")
    levels = voxscope.convert.finalize(plan)
    print(f"wrote {plan} ({len(levels)} levels) in {time.time() - started:.2f} s")


if __name__ == "__main__":
    main()
