"""The ``acrobot-mj`` command. It loads the package (about a second) only after a Ctrl-C or a
SIGTERM would end it quietly, then :func:`acrobot_mj.cli.main` takes over the stops (runs save
their checkpoints). It lives outside the package because importing anything inside it loads
the package first."""

from __future__ import annotations

import os
import signal
import sys


def _stopped_while_loading(signum: int, frame: object) -> None:
    # os._exit: nothing is written yet, and an exception raised while numba loads its cache
    # would be dropped in a C callback.
    what = "terminated (SIGTERM)" if signum == signal.SIGTERM else "interrupted"
    os.write(2, f"acrobot-mj: {what} while starting\n".encode())
    os._exit(128 + signum)


def main() -> int:
    """Run the command line, stoppable from its first instant."""
    signal.signal(signal.SIGINT, _stopped_while_loading)
    signal.signal(signal.SIGTERM, _stopped_while_loading)
    from acrobot_mj.cli import main as cli_main

    return cli_main()


if __name__ == "__main__":
    sys.exit(main())
