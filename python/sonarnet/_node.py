"""The node program of runs on node processes started from Python.

The coordinator (a ``Scenario.run(engine="processes")``) starts one
``python -m sonarnet._node --launch JSON`` per receiver; the program is the
library's ``sonarnet-node``, compiled into the extension. The package also
installs it as the ``sonarnet-node`` command.
"""

import signal
import sys


def main() -> None:
    # The node program handles SIGINT and SIGTERM itself (it stops in
    # order); the interpreter must not turn them into KeyboardInterrupt.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from sonarnet._sonarnet import _node_main

    sys.exit(_node_main(["sonarnet-node"] + sys.argv[1:]))


if __name__ == "__main__":
    main()
