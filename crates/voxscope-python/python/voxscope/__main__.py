"""`python -m voxscope ARGS` (and the `voxscope` script pip installs): the command line,
`voxscope ARGS`: render, info, convert, bench, … and, without a command, the app."""

import sys


def main() -> None:
    """Runs the command line on this process's arguments; exits with its status (3: a render
    whose image is incomplete), or 1 with its one-line error."""
    from ._voxscope import VoxscopeError, run_command_line

    try:
        status = run_command_line(["voxscope", *sys.argv[1:]])
    except VoxscopeError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(1)
    sys.exit(status)


if __name__ == "__main__":
    main()
