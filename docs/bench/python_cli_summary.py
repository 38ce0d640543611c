"""The one line python-cli.sh ends with: Python's frame beside the command line's, DVR and MIP.

usage: python3 python_cli_summary.py PYTHON.jsonl CLI.json

PYTHON.jsonl: peer_bench.py's rows (voxscope's `ms_batch`: `frames` draw() calls of an orbit at
3 radii, then finish()). CLI.json: `voxscope bench --renderer bricks --json` of the same voxels,
frames and orbit (its `medium` rows' `wall_ms_per_frame`: the turn's frames submitted back to
back, then the device's completion). Prints
`python-cli DVR python P ms cli C ms ratio R; MIP python P ms cli C ms ratio R`, and a warning
line first where the two did not draw the same number of frames at the same size. Where
PYTHON.jsonl also holds python_steady.py's rows (`voxscope-steady`: the median of 5 batches per
pass, once the GPU's clocks are up), a second line `python-cli steady …` compares those.
"""
import json
import sys

# The command line's row each Python mode compares with.
MODES = (("DVR", "dvr", "dvr-gray"), ("MIP", "mip", "mip"))


def shown(ms):
    """Milliseconds as the line shows them ('?': missing)."""
    return f"{ms:.3f}" if ms else "?"


def main(python_path, cli_path):
    rows = [json.loads(line) for line in open(python_path) if line.startswith("{")]
    python = {r["mode"]: r for r in rows if r.get("peer") == "voxscope"}
    cli = json.load(open(cli_path))
    medium = {r["mode"]: r for r in cli["results"]
              if r["renderer"] == "bricks" and r["camera"] == "medium"}
    for r in python.values():
        if (r["frames"], [r["w"], r["h"]]) != (cli["frames"], cli["size"]):
            print(f"# WARNING: Python drew {r['frames']} frames at {r['w']}x{r['h']}, the command "
                  f"line {cli['frames']} at {cli['size'][0]}x{cli['size'][1]}")
            break
    parts = []
    for name, python_mode, cli_mode in MODES:
        p = python.get(python_mode, {}).get("ms_batch")
        c = medium.get(cli_mode, {}).get("wall_ms_per_frame")
        ratio = f"{p / c:.2f}" if p and c else "?"
        parts.append(f"{name} python {shown(p)} ms cli {shown(c)} ms ratio {ratio}")
    print("python-cli " + "; ".join(parts))
    steady = [r for r in rows if r.get("peer") == "voxscope-steady"]
    if steady:
        parts = []
        for name, python_mode, cli_mode in MODES:
            ms = [r["ms_batch"] for r in steady if r["mode"] == python_mode]
            p = sorted(ms)[len(ms) // 2] if ms else None
            c = medium.get(cli_mode, {}).get("wall_ms_per_frame")
            ratio = f"{p / c:.2f}" if p and c else "?"
            passes = "/".join(f"{m:.3f}" for m in ms)
            parts.append(f"{name} python {shown(p)} ms ({passes}) cli {shown(c)} ms ratio {ratio}")
        print("python-cli steady " + "; ".join(parts))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], sys.argv[2])
