"""The child process of `view()`: `python -m voxscope._app [--remove FOLDER] -- ARGS` runs the
app (`voxscope ARGS`) and, once its window closes, removes FOLDER (the temporary file an array
was written to)."""

import shutil
import sys


def main(argv: list) -> int:
    """Runs the app on `argv`; returns the exit status."""
    from ._voxscope import VoxscopeError, run_command_line

    remove = None
    if argv[:1] == ["--remove"]:
        remove, argv = argv[1], argv[2:]
    if argv[:1] == ["--"]:
        argv = argv[1:]
    try:
        return run_command_line(["voxscope", *argv])
    except VoxscopeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    finally:
        if remove:
            shutil.rmtree(remove, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
