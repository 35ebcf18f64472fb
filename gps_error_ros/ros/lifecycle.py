"""
The one ``main()`` of the nodes: start, spin, and stop cleanly every time.

Exit codes: 0 after Ctrl-C, SIGTERM or an external shutdown (the node's
shutdown work done first); 2 for a bad parameter or a command line rcl
cannot parse, with a one-line message naming it.

A node with many publishers (a crowd) ends its process without destroying
them one by one: Fast DDS takes some 5-10 ms per publisher, minutes for
thousands of agents (see docs/decisions/0011-a-crowd-exits-at-once.md).
"""

from collections.abc import Callable, Sequence
import ctypes
import os
import re
import signal
import sys
from typing import Any, NoReturn

import rclpy
from rclpy.executors import ExternalShutdownException

from gps_error_ros.ros.parameters import ConfigError


def command_line_problem(exc: BaseException) -> str:
    """Return rcl's complaint about the command line as one readable line."""
    text = str(exc).replace('failed to initialize rcl: ', '')
    text = re.sub(r', at /\S+:\d+', '', text).strip()
    if 'Sequence should be of same type' in text:
        text += (' (a list holds one type: write every number of a list with a '
                 'decimal point, e.g. [40.75, -73.99, 0.0])')
    return text


def wants_help(args: Sequence[str] | None = None) -> bool:
    """Return True when ``--help`` or ``-h`` comes before any ROS arguments."""
    argv = sys.argv[1:] if args is None else list(args)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    return '--help' in argv or '-h' in argv


def run_node(make_node: Callable[[], Any], name: str, args: Sequence[str] | None = None,
             at_shutdown: Callable[[Any], str | None] | None = None,
             help_text: str | None = None) -> int:
    """
    Run the node that ``make_node()`` builds until shutdown; return the exit code.

    With ``--help`` (before ``--ros-args``) print ``help_text`` and exit 0
    without starting ROS.

    ``at_shutdown(node)`` runs before the node is destroyed and returns a
    line to log (or None); the line is logged after the node is gone, so that
    no log message goes to a ``/rosout`` whose context is already shut down.
    """
    if help_text is not None and wants_help(args):
        print(help_text)
        return 0
    asked = _quiet_stop_signals()
    try:
        rclpy.init(args=None if args is None else list(args))
    except RuntimeError as exc:          # rcl's parser refused the arguments
        print(f'{name}: cannot parse the command line: '
              f'{command_line_problem(exc)}', file=sys.stderr)
        return 2
    if asked:                            # stopped before rclpy's handlers were in
        rclpy.try_shutdown()
        return 0
    logger = rclpy.logging.get_logger(name)
    node, code, last_words, at_once = None, 0, None, 0
    try:
        node = make_node()
        _spin(node, logger)
    except ConfigError as exc:
        logger.fatal(str(exc))
        code = 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # A signal can shut the context down while the executor builds its
        # wait set (rcl: "the given context is not valid"): that is the
        # shutdown asked for, not a failure. Anything else is re-raised.
        if rclpy.ok():
            raise
    finally:
        # Shutting down: a second Ctrl-C or SIGTERM must not cut the writing.
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        if node is not None:
            if at_shutdown is not None:
                last_words = at_shutdown(node)
            at_once = sum(1 for _ in node.publishers)
            if at_once <= QUICK_EXIT_PUBLISHERS:
                at_once = 0
                node.destroy_node()
        _shutdown_context()
    if last_words:
        logger.info(last_words)
    if at_once:
        logger.info(f'ending without destroying its {at_once} publishers one by one: '
                    f'peers drop them when the process\'s DDS lease runs out')
        exit_at_once(code)
    return code


def exit_at_once(code: int) -> NoReturn:
    """
    End the process now with ``code``, its output flushed, no entity destroyed.

    The context is shut down already (its log files closed). Peers see the
    process's topics go when its DDS participant's lease runs out, as after
    a kill; destroying thousands of publishers one by one took minutes.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    ctypes.CDLL(None).fflush(None)        # C stdio: rcutils writes the console log
    os._exit(code)


#: More publishers than this, and the process ends without destroying them.
QUICK_EXIT_PUBLISHERS = 200

#: What rclpy says when a message taken from the middleware cannot be made a Python object.
UNTAKEABLE = 'Unable to convert call argument'


def _spin(node: Any, logger: Any) -> None:
    """
    Spin ``node`` until its context shuts down, past a message rclpy cannot take.

    rclpy raises ``RuntimeError`` (pybind11: "Unable to convert call
    argument ...") when building the Python message fails, as it did when
    a KeyboardInterrupt landed inside the conversion (seen in the test suite
    on a loaded 2-core machine before :func:`_quiet_stop_signals`: the node
    then exited with status 1). That one message is dropped with a warning
    and spinning goes on.
    """
    # A stop can come while the node is being built. rclpy then cannot build
    # its executor on the shut context (TypeError), or hands out none (None:
    # the context shut down as it built one). Either way nothing is left to spin.
    try:
        executor = rclpy.get_global_executor() if node.context.ok() else None
    except TypeError:
        if node.context.ok():
            raise
        executor = None
    if executor is None:
        return
    executor.add_node(node)
    try:
        while node.context.ok():
            try:
                executor.spin_once()
            except RuntimeError as exc:
                if UNTAKEABLE not in str(exc) or not node.context.ok():
                    raise
                logger.warning(f'a message could not be taken from the middleware and was '
                               f'dropped: {exc}')
    finally:
        executor.remove_node(node)


def _quiet_stop_signals() -> list[int]:
    """
    Make Ctrl-C and SIGTERM raise nothing in Python; return the list they are noted in.

    rclpy's own handlers (installed by ``rclpy.init``, which chain to these)
    shut the context down, and spinning ends on that. Python's default
    KeyboardInterrupt would instead land at any bytecode: inside an rclpy
    Task's constructor (a "Future.__del__" traceback), inside the conversion
    of a message taken from the middleware, or inside the shutdown work.
    """
    asked: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: asked.append(signum))
    return asked


def _shutdown_context() -> None:
    """Shut the context down unless a signal handler already did (a race)."""
    try:
        rclpy.try_shutdown()
    except RuntimeError:
        if rclpy.ok():
            raise
