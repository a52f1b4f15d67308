"""How every node process runs: init, an EventsExecutor in a spin_once loop, clean exit codes.

architecture.md measured EventsExecutor in a spin_once loop as the fastest
reliable choice here (MultiThreadedExecutor and background spinning hung).
A node ends the loop by calling :meth:`GraphNode.finish`; a fatal problem
becomes one line on stderr and a non-zero exit code, never a traceback.
"""
from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import dataclass

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_BAD_INPUT = 2
EXIT_TIMEOUT = 3
# after its work is done (bag closed, last message acknowledged) a node gets this long to tear its DDS
# entities down; a teardown stuck past it dumps every thread's stack to the log and the process ends by
# SIGALRM, which the launcher reads as "done, teardown hung" (runner/launcher.py TEARDOWN_HUNG)
POLL_PERIOD = 0.005   # [s] wall time between two GraphNode.poll calls of a node while callbacks keep coming
TEARDOWN_TIMEOUT = int(os.environ.get("RW_FDI_TEARDOWN_TIMEOUT", "10"))   # the environment: tests
PARENT_GONE_S = 1   # [s] to close after the launcher died (kill -9): gone well within the 2 s docs/running.md says


@dataclass
class _WriterWatch:
    """The writers of /plant/done (and of a node's inputs) as a node following the run end last looked: the
    topics watched, seen once, all gone since [monotonic s] (None while one is here), when to look next
    [monotonic s]."""

    topics: tuple = ()
    seen: bool = False
    gone_since: float | None = None
    next_look: float = 0.0


class NodeError(RuntimeError):
    """A fatal, explained problem: the process prints the message and exits with ``code``."""

    def __init__(self, message: str, code: int = EXIT_ERROR):
        super().__init__(message)
        self.code = code


def relative(topic: str) -> str:
    """A graph topic's name relative to the node's namespace ('/attitude' -> 'attitude'): the table's names
    (graph/topics.py) are what a graph without a namespace has, and what a bag records; a node resolves
    them in its namespace, so two spacecraft share a ROS graph under /sc1 and /sc2 without cross-talk.

    Parameters
    ----------
    topic : str
        A graph topic's name, e.g. '/attitude'.

    Returns
    -------
    str
        The name without its leading '/'.
    """
    return topic[1:] if topic.startswith("/") else topic


class GraphNode(Node):
    """A node whose process ends when it says so (finish/fail), not only on a signal. Its topics are the
    graph table's names resolved in its namespace (:func:`relative`). Its name is the class' ``node_name``
    unless given another (composition)."""

    def __init__(self, name: str | None = None, **kwargs):
        super().__init__(name or self.node_name, **kwargs)
        self.exit_code: int | None = None
        self.exit_message = ""
        self.unheard = []   # the inputs that must hear a writer before this node says it is ready

    def say_ready_when_heard(self, subscriptions):
        """Say this node's name on /graph/ready (latched) once each of ``subscriptions`` hears a writer. DDS
        matches each direction on its own: a writer that counts this node's reader does not mean the reader
        hears it, and a sample sent before then is lost for good (a CI run's controller never heard step 0).
        The plant starts once every node of its ``ready_nodes`` has said so.

        Parameters
        ----------
        subscriptions : list of rclpy.subscription.Subscription or (Subscription, int)
            The inputs the node steps on (not the optional ones), each with the writers to hear (default 1; a
            topic the node writes too counts its own writer).
        """
        from std_msgs.msg import String
        from . import topics as T
        self.unheard = [s if isinstance(s, tuple) else (s, 1) for s in subscriptions]
        self.pub_heard = self.create_publisher(String, T.NODE_READY, T.LATCHED)
        self.ready_message = String(data=self.get_name())

    def say_ready(self):
        """Called before each :meth:`poll`: says ready once every input of :meth:`say_ready_when_heard` hears."""
        if self.unheard and all(s.get_publisher_count() >= n for s, n in self.unheard):
            self.unheard = []
            self.pub_heard.publish(self.ready_message)

    def create_publisher(self, msg_type, topic, *args, **kwargs):
        """rclpy's, with ``topic`` resolved in the node's namespace (:func:`relative`).

        Parameters
        ----------
        msg_type : type
            The message class.
        topic : str
            The graph topic's name (graph/topics.py).
        *args, **kwargs
            rclpy's (QoS, callback group, ...).

        Returns
        -------
        rclpy.publisher.Publisher
            The publisher.
        """
        return super().create_publisher(msg_type, relative(topic), *args, **kwargs)

    def create_subscription(self, msg_type, topic, *args, **kwargs):
        """rclpy's, with ``topic`` resolved in the node's namespace (:func:`relative`).

        Parameters
        ----------
        msg_type : type
            The message class.
        topic : str
            The graph topic's name (graph/topics.py).
        *args, **kwargs
            rclpy's (callback, QoS, callback group, ...).

        Returns
        -------
        rclpy.subscription.Subscription
            The subscription.
        """
        return super().create_subscription(msg_type, relative(topic), *args, **kwargs)

    def declare_parameter(self, name, value=None, descriptor=None, ignore_override=False):
        """rclpy's, with the parameter's range (graph/parameters.py) in its descriptor: a value out of it,
        or a non-finite float, ends the node with one line naming the parameter before it starts.

        Parameters
        ----------
        name : str
            The parameter's name.
        value : object, optional
            Its default value.
        descriptor : rcl_interfaces.msg.ParameterDescriptor, optional
            Its descriptor; None: the range graph/parameters.py gives it.
        ignore_override : bool
            rclpy's: ignore a value given at start-up.

        Returns
        -------
        rclpy.parameter.Parameter
            The declared parameter.
        """
        from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
        from .parameters import descriptor as ranged, finite
        descriptor = descriptor or ranged(getattr(type(self), "node_name", self.get_name()), name, value)
        try:
            parameter = super().declare_parameter(name, value, descriptor, ignore_override) if descriptor \
                else super().declare_parameter(name, value, ignore_override=ignore_override)
        except (InvalidParameterValueException, InvalidParameterTypeException) as exc:
            reason = str(exc).split("Reason: ", 1)[-1].removesuffix(f": {name}")
            raise NodeError(reason if name in reason else f"parameter {name}: {reason}", EXIT_BAD_INPUT) from None
        if not finite(parameter.value):
            raise NodeError(f"parameter {name}: {parameter.value} is not a finite number", EXIT_BAD_INPUT)
        return parameter

    def follow_run_end(self, grace: float = 10.0, period: float = 0.0, inputs: tuple = ()):
        """End this node once the plant has published /plant/done and this node has handled its
        last stamp (``self.last_handled``): the done stamp itself, or with ``period`` the last
        multiple of it. ``grace`` wall seconds after done is only a safety net. Parameter
        ``end_with_run`` false keeps the node for the next run (bag replay of many runs through one
        graph); whoever started it stops it. A done that never arrives ends the node ``grace`` seconds
        after the writers it was watching left: the done writer's (gone before this reader acknowledged
        it, on a loaded machine), or, where this node never discovered it, those of its ``inputs``
        (an FDI node hears the run from wheel_telemetry, not the plant).

        Parameters
        ----------
        grace : float
            Wall time after done without a new stamp handled (or after the writers left) the node ends
            at the latest [s].
        period : float
            The node's handling period [s]; 0: the done stamp itself is the last one handled.
        inputs : tuple of str
            Graph topics this node reads whose writers leaving also ends the run for it.
        """
        from std_msgs.msg import Header
        from . import topics as T
        from .convert import stamp_ns
        self.last_handled = -1
        self._run_end = None
        self._done_writer = None
        self.declare_parameter("end_with_run", True)
        if not self.param("end_with_run"):
            return
        self._done_writer = _WriterWatch(topics=tuple(relative(t) for t in (T.PLANT_DONE, *inputs)))
        self._run_end_grace = grace

        period_ns = int(round(period * 1e9))

        def on_done(msg):
            last = stamp_ns(msg.stamp)
            if period_ns > 0:
                last -= last % period_ns
            self._run_end = (last, time.monotonic() + grace, self.last_handled)
        self.create_subscription(Header, T.PLANT_DONE, on_done, T.LATCHED)

    def run_ended(self) -> bool:
        """Whether the run this node follows has ended (see :meth:`follow_run_end`).

        Returns
        -------
        bool
            True once the last stamp is handled, the grace time is over, or the done writer left.
        """
        end = getattr(self, "_run_end", None)
        if end is None:
            return self._done_writer_left()
        if self.last_handled >= end[0]:
            return True
        now = time.monotonic()
        if self.last_handled != end[2]:   # progress: the grace counts from the last stamp handled
            self._run_end = end = (end[0], now + self._run_end_grace, self.last_handled)
        return now > end[1]

    def _done_writer_left(self) -> bool:
        """Whether the writers watched (of /plant/done: the plant, the player; of the inputs) were here and
        have all been gone ``grace`` seconds without this node hearing done: nothing more will come. Looked
        at once a second."""
        watch = getattr(self, "_done_writer", None)
        now = time.monotonic()
        if watch is None:
            return False
        if watch.gone_since is not None and now - watch.gone_since > self._run_end_grace:
            return True
        if now < watch.next_look:
            return False
        from . import topics as T
        watch.next_look = now + 1.0
        if any(self.count_publishers(topic) > 0 for topic in watch.topics):
            watch.seen, watch.gone_since = True, None
            return False
        if not watch.seen:
            return False
        if watch.gone_since is None:
            watch.gone_since = now
            self.get_logger().warn(f"the writers of {', '.join(watch.topics)} left without this node hearing "
                                   f"{T.PLANT_DONE}; ending {self._run_end_grace:.0f} s after")
        return now - watch.gone_since > self._run_end_grace

    def finish(self, code: int = EXIT_OK, message: str = ""):
        """Mark the node finished with ``code`` (the first call wins).

        Parameters
        ----------
        code : int
            The exit code.
        message : str
            One line saying why, for the log.
        """
        if self.exit_code is None:
            self.exit_code, self.exit_message = code, message

    def fail(self, message: str, code: int = EXIT_ERROR):
        """Mark the node failed: :meth:`finish` with an error code.

        Parameters
        ----------
        message : str
            One line saying why, for the log.
        code : int
            The exit code.
        """
        self.finish(code, message)

    def poll(self):
        """Called between callbacks, every POLL_PERIOD while they keep coming and at least every 50 ms:
        timeouts and start-up gates live here, never a step of the run."""

    def close(self):
        """Called once on the way out, also after a signal. By default: let every reader have what
        was published before the process and its DDS writers go away."""
        from rclpy.duration import Duration
        if not self.context.ok():
            return  # after a signal the context is gone; nothing can be acknowledged any more
        for pub in list(self.publishers):
            try:
                pub.wait_for_all_acked(Duration(seconds=2.0))
            except Exception:  # a writer torn down under us: nothing left to wait for
                pass

    def timing(self) -> dict:
        """Figures for ``rw-fdi bench`` (printed at exit when RW_FDI_TIMING=1).

        Returns
        -------
        dict
            Figure name -> value; empty here, nodes that time themselves override it.
        """
        return {}

    def param(self, name):
        """A parameter's value; None for a declared-but-unset typed parameter.

        Parameters
        ----------
        name : str
            The parameter's name.

        Returns
        -------
        object or None
            Its value.
        """
        from rclpy.exceptions import ParameterUninitializedException
        try:
            return self.get_parameter(name).value
        except ParameterUninitializedException:
            return None


class ReadySignal:
    """Whether the readers that must hear a run from its first message have said so on their latched ``topic``:
    /recorder/ready (default: the recorder hears the graph's writers) or /graph/ready, where each node of
    ``names`` says it hears its inputs (GraphNode.say_ready_when_heard). A writer that counts a reader does not
    mean the reader has matched the writer: the plant and the player start on these. True at once when not
    ``wanted``."""

    def __init__(self, node: Node, wanted: bool, topic: str | None = None, names=()):
        self.seen, self.waiting = not wanted, set(names)
        if wanted:
            from copy import copy
            from std_msgs.msg import String
            from . import topics as T
            self.topic = topic or T.RECORDER_READY
            qos = copy(T.LATCHED)   # one writer per node, and a reader of depth 1 would keep only the last one's
            qos.depth = max(1, len(self.waiting))
            node.create_subscription(String, self.topic, self._on_ready, qos)

    def _on_ready(self, msg):
        self.waiting.discard(msg.data)
        self.seen = not self.waiting

    def missing(self) -> str:
        """What it still waits for, for an error line.

        Returns
        -------
        str
            The topic, and the nodes not heard on it.
        """
        return self.topic + (f" ({', '.join(sorted(self.waiting))} not heard)" if self.waiting else "")


def spin_node(factory, args=None) -> int:
    """Create the node, spin it until it finishes or a signal arrives, and return the exit code.

    Parameters
    ----------
    factory : callable
        Returns the GraphNode.
    args : list of str, optional
        rclpy's command-line arguments.

    Returns
    -------
    int
        The exit code.
    """
    return spin_nodes([factory], args)


def die_with_parent():
    """A node process our launcher started ends with it: killed with -9, `rw-fdi` can stop nothing itself, so
    the kernel sends the SIGINT the launcher would have (Linux prctl PR_SET_PDEATHSIG: the recorder still closes
    its bag). ``RW_FDI_PARENT_PID`` (launcher.ros_environment) names the parent; a launcher gone before this ran
    is seen at once. The end is bounded: PARENT_GONE_S after the parent's death the kernel ends the process
    (a loaded machine took 5 s to close every node). Nodes started otherwise (ros2 launch, ros2 run) are left to
    their own launcher."""
    parent = os.environ.get("RW_FDI_PARENT_PID")
    if not parent or not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    def parent_died(signum, frame):
        # the graceful end, bounded: after PARENT_GONE_S the kernel ends the process (SIGALRM), GIL or not
        signal.alarm(PARENT_GONE_S)
        raise KeyboardInterrupt
    signal.signal(signal.SIGUSR2, parent_died)
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGUSR2))
    if os.getppid() != int(parent):
        os.kill(os.getpid(), signal.SIGUSR2)


def spin_nodes(factories, args=None) -> int:
    """Create the nodes (one each of ``factories``: callables returning a GraphNode), spin them in one
    executor until every one has finished, one fails, or a signal arrives; the exit code (the first
    failure's). One factory is a node's own process; several are ROS 2 composition as rclpy has it
    (nodes/composed.py): separate node objects, names, parameters and topics, one executor. A node
    that finishes is closed at once (a recorder's bag is final) and spins no more.

    Parameters
    ----------
    factories : sequence of callable
        Each returns a GraphNode.
    args : list of str, optional
        rclpy's command-line arguments.

    Returns
    -------
    int
        The exit code (the first failure's; 0 when every node finished well).
    """
    import faulthandler
    import signal
    # `kill -USR1 <pid>` (the launcher does, on a node that does not end) writes where it is to its log
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    rclpy.init(args=args)
    die_with_parent()   # after init: the SIGINT it may send is rclpy's to handle
    nodes, closed = [], set()
    name = getattr(factories[0], "node_name", "node") if factories else "node"
    failed = None   # (name, code, message) of the first node that failed
    try:
        for factory in factories:
            name = getattr(factory, "node_name", "node")
            nodes.append(factory())
        # rclpy's logger finds its caller through inspect, whose first look scans every module loaded (20-40 ms of
        # CPU): taken here, at start-up, not in the first callback that logs (FDIR's first decision, bench fdi)
        import inspect
        inspect.getframeinfo(inspect.currentframe())
        from rclpy.experimental import EventsExecutor
        executor = EventsExecutor()
        # what start-up made (modules, models, the identification's buffers) lives as long as the process: out of
        # the cyclic collector's way, whose full passes over it cost a callback 10 ms at a time (bench fdi)
        import gc
        gc.collect()
        gc.freeze()
        for node in nodes:
            executor.add_node(node)
        profile_dir = os.environ.get("RW_FDI_PROFILE")  # developer aid: cProfile each process
        if profile_dir:
            import cProfile
            profiler = cProfile.Profile()
            profiler.enable()
        live = list(nodes)
        last_poll = 0.0
        while live and failed is None:
            executor.spin_once(timeout_sec=0.05)
            # polls (timeouts, start-up gates) every POLL_PERIOD, not after every callback: a lockstep step
            # is some thirty callbacks, and polling every node after each cost more than the step itself
            now = time.monotonic()
            due = now - last_poll >= POLL_PERIOD
            if due:
                last_poll = now
                if not rclpy.ok():   # shut down (a signal): what each node did so far is its outcome
                    break
            for node in list(live):
                if due and node.exit_code is None:
                    node.say_ready()
                    node.poll()
                if node.exit_code is None:
                    continue
                live.remove(node)
                if node.exit_code != EXIT_OK:
                    failed = (node.get_name(), node.exit_code, node.exit_message)
                    break
                if len(nodes) > 1:   # composed: its work is done, the others go on
                    executor.remove_node(node)
                    _close(node, closed)
        if profile_dir:
            profiler.disable()
            profiler.dump_stats(os.path.join(profile_dir, f"{nodes[0].get_name()}.prof"))
    except NodeError as exc:
        failed = (name, exc.code, str(exc))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:  # a bug: still one line, with the type
        failed = (name, EXIT_ERROR, f"{type(exc).__name__}: {exc}")
    finally:
        outcome = {}   # node name -> (code, message), in the nodes' order
        for node in nodes:
            problem = _close(node, closed)
            outcome[node.get_name()] = ((EXIT_ERROR, problem) if problem else
                                        (node.exit_code or EXIT_OK, node.exit_message))
        if failed is not None:
            outcome[failed[0]] = failed[1:]
        _tear_down(nodes, outcome)
    if os.environ.get("RW_FDI_TIMING") == "1":
        for node, node_name in zip(nodes, outcome):   # a destroyed node no longer says its name
            report = {"node": node_name, "cpu_s": time.process_time(), "max_rss_mb": _peak_rss_mb(),
                      "process_nodes": len(nodes), "pid": os.getpid(), "torch_imported": "torch" in sys.modules,
                      **node.timing()}
            print("RW_FDI_TIMING " + json.dumps(report), flush=True)
    codes = [code for code, _ in outcome.values() if code != EXIT_OK]
    return codes[0] if codes else EXIT_OK


def _close(node, closed: set) -> str:
    """Close ``node`` once; what went wrong closing it ('' when nothing)."""
    if id(node) in closed:
        return ""
    closed.add(id(node))
    try:
        node.close()
    except Exception as exc:  # noqa: BLE001 -- said, and the process fails
        return f"while closing: {type(exc).__name__}: {exc}"
    return ""


def _tear_down(nodes, outcome: dict):
    """Destroy the nodes and shut rclpy down, watched: their work is done, and a DDS teardown that
    never returns must not hold the run. Each node's message (``outcome``: name -> (code, message)) is
    said first, so the log has it either way."""
    import faulthandler
    import signal
    for name, (code, message) in outcome.items():
        if message:
            print(f"{name}: {'error: ' if code else ''}{message}", file=sys.stderr, flush=True)
    faulthandler.dump_traceback_later(TEARDOWN_TIMEOUT - 1, exit=False)
    pending = signal.alarm(0)   # an earlier deadline (the parent gone: die_with_parent) stays the deadline
    signal.alarm(min(pending, TEARDOWN_TIMEOUT) if pending else TEARDOWN_TIMEOUT)   # the kernel ends it, GIL or not
    for node in nodes:
        node.destroy_node()
    rclpy.try_shutdown()
    signal.alarm(0)
    faulthandler.cancel_dump_traceback_later()


def _peak_rss_mb() -> float:
    """VmHWM of this process image: getrusage's ru_maxrss would also count the launcher's pages
    inherited through fork before exec."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def main_for(factory):
    """A console-script entry point for ``factory`` (kept as ``main.factory``: composition makes its nodes).

    Parameters
    ----------
    factory : callable
        Returns the GraphNode.

    Returns
    -------
    callable
        ``main(args=None)``, which spins the node and exits with its code.
    """
    def main(args=None):
        exit_watched(spin_node(factory, args=args if args is not None else sys.argv))
    main.factory = factory
    return main


def exit_watched(code: int):
    """Exit with ``code``; the interpreter's own exit (DDS threads, destructors) is watched too.

    Parameters
    ----------
    code : int
        The exit code.
    """
    import signal
    signal.alarm(TEARDOWN_TIMEOUT)
    sys.exit(code)


def wall_time() -> float:
    """Monotonic wall time [s] (for timeouts and figures, never for the simulated clock).

    Returns
    -------
    float
        time.monotonic() [s].
    """
    return time.monotonic()
