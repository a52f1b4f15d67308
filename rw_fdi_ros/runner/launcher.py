"""Our launcher: every node its own process, a private DDS domain, supervised to the end.

No ``ros2 launch`` exists on these machines, so this is what the CLI and CI
use. It never hangs: a node that dies ends the run with its own one-line
reason; a graph that stops making progress is killed after a watchdog;
hung rclpy processes (they swallow SIGTERM) get SIGKILL after a grace
period. The recorder is always asked to finalise the bag before that.
"""
from __future__ import annotations

import fcntl
import itertools
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from ..paths import fastdds_profiles, installed_executable
from .shm import clean_zombie_files

# a node that did its work and then hung tearing DDS down ends by SIGALRM (nodes/runtime.TEARDOWN_TIMEOUT):
# that is a clean exit with a note, not a failed node
TEARDOWN_HUNG = -signal.SIGALRM
DOMAIN_RANGE = range(101, 233)   # 0..232 is valid; low ids stay free for people's own graphs
_LOCK_DIR = Path(tempfile.gettempdir()) / "rw_fdi_ros_domains"
_LEASES = itertools.count()


class DomainLease:
    """An exclusive ROS_DOMAIN_ID for this process tree, held by an flock until released."""

    def __init__(self, preferred: int | None = None):
        _LOCK_DIR.mkdir(exist_ok=True)
        candidates = list(DOMAIN_RANGE)
        # each lease of a process starts elsewhere: a run does not reuse the domain the run before it just
        # left, where a participant that was killed may still hold shared-memory ports for a while
        start = (os.getpid() * 7 + next(_LEASES) * 31) % len(candidates)
        candidates = candidates[start:] + candidates[:start]
        if preferred is not None:
            candidates = [preferred] + [c for c in candidates if c != preferred]
        for domain in candidates:
            fh = open(_LOCK_DIR / f"{domain}.lock", "w")
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                fh.close()
                continue
            self.domain_id, self._fh = domain, fh
            return
        raise RuntimeError("no free ROS_DOMAIN_ID in 101..232 (too many runs at once)")

    def release(self):
        if self._fh:
            self._fh.close()
            self._fh = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def ros_environment(domain_id: int, log_dir: Path) -> dict:
    """Environment for node processes: loopback-only discovery on a private domain.

    Parameters
    ----------
    domain_id : int
        The ROS_DOMAIN_ID (a :class:`DomainLease`'s).
    log_dir : Path
        The nodes' ROS_LOG_DIR.

    Returns
    -------
    dict of str to str
        This process's environment with the ROS, RMW and Fast DDS settings of the graph.
    """
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=str(log_dir), RMW_IMPLEMENTATION="rmw_fastrtps_cpp", PYTHONUNBUFFERED="1",
               RW_FDI_PARENT_PID=str(os.getpid()))   # the nodes end with us (runtime.die_with_parent)
    if fastdds_profiles():
        env["FASTDDS_DEFAULT_PROFILES_FILE"] = fastdds_profiles()
    env.pop("ROS_LOCALHOST_ONLY", None)   # ignored by kilted; do not pretend it helps
    env.pop("ROS_STATIC_PEERS", None)
    return env


def stop_processes(procs, grace: float = 3.0, sig=signal.SIGINT):
    """Ask all politely at once, then SIGKILL what is left: rclpy swallows SIGTERM when hung.

    Parameters
    ----------
    procs : iterable of subprocess.Popen
        The processes (those already ended are left alone).
    grace : float
        Wall time [s] all of them together get to end after ``sig``.
    sig : int
        The polite signal.

    Returns
    -------
    None
    """
    live = [p for p in procs if p.poll() is None]
    for p in live:
        try:
            p.send_signal(sig)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + grace
    for p in live:
        try:
            p.wait(timeout=max(deadline - time.monotonic(), 0.01))
        except subprocess.TimeoutExpired:
            p.kill()
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:   # stuck in the kernel: nothing more to do from here
                pass


class _QuotingDumper(yaml.SafeDumper):
    """Quotes every string: rcl's YAML reads a bare 'y' (the axis) as a boolean. Writes no alias: rcl refuses
    them, and the nodes share one ``fdi`` parameter set."""

    def ignore_aliases(self, data):
        return True


_QuotingDumper.add_representer(str, lambda d, v: d.represent_scalar("tag:yaml.org,2002:str", v, style="'"))


def write_params_file(nodes, path: Path, namespace: str = "") -> Path:
    """The ``--params-file`` every node reads (rcl parses it as YAML, as it does launch_ros' files):
    every string quoted, so `y`, `on` or `1.5` given as strings stay strings.

    Parameters
    ----------
    nodes : iterable of NodeSpec
        The graph's nodes (names and parameters).
    path : str or Path
        The file to write.

    Returns
    -------
    Path
        ``path``.
    """
    # under a namespace rcl matches a node by its full name: /** takes the node in any namespace
    params = {(f"/**/{n.name}" if namespace else n.name): {"ros__parameters": n.parameters} for n in nodes}
    Path(path).write_text(yaml.dump(params, Dumper=_QuotingDumper, sort_keys=False))
    return Path(path)


@dataclass
class GraphResult:
    ok: bool
    reason: str
    wall_time: float
    exit_codes: dict
    log_dir: Path | None = None


def _last_line(path: Path) -> str:
    try:
        lines = [ln.strip() for ln in path.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    errors = [ln for ln in lines if ": error: " in ln]
    return (errors or lines or [""])[-1][:300]


def node_command(n, params_file, python: str = sys.executable, namespace: str = "") -> list:
    """The command line of one node: what launch_ros' Node(name=..., parameters=[file]) gives, no remapping
    but the node's name. On an install the files `ros2 run` starts; in a source tree the modules.

    Parameters
    ----------
    n : NodeSpec
        The node.
    params_file : str or Path
        The ``--params-file`` (:func:`write_params_file`).
    python : str
        The interpreter that runs a module.

    Returns
    -------
    list of str
        The command line.
    """
    return _command(n.executable, n.module, [], ["-r", f"__node:={n.name}"], params_file, python, namespace)


def _command(executable: str, module: str, args: list, remaps: list, params_file, python: str, namespace: str):
    """``executable`` installed, or ``module`` run by ``python``, with ``args`` and its ROS arguments: ``remaps``,
    the remapping that puts every node of the process in ``namespace`` (none for ''), the parameters file."""
    exe = installed_executable(executable)
    return ([str(exe)] if exe else [python, "-m", module]) + args + [
        "--ros-args", *remaps, *(["-r", f"__ns:=/{namespace.strip('/')}"] if namespace else []),
        "--params-file", str(params_file), "--log-level", "warn"]


def process_command(process, params_file, python: str = sys.executable, namespace: str = "") -> list:
    """The command line of one process of the graph (runner.graph.ProcessSpec): a node's own, or the composed
    executable with NAME=EXECUTABLE per node (no name remapping: it would rename all of them).

    Parameters
    ----------
    process : ProcessSpec
        The process and its nodes.
    params_file : str or Path
        The ``--params-file`` (:func:`write_params_file`).
    python : str
        The interpreter that runs a module.

    Returns
    -------
    list of str
        The command line.
    """
    if len(process.nodes) == 1:
        return node_command(process.nodes[0], params_file, python, namespace)
    return _command("composed", "rw_fdi_ros.nodes.composed", [f"{n.name}={n.executable}" for n in process.nodes], [],
                    params_file, python, namespace)


class GraphProcesses:
    """Start a list of :class:`NodeSpec` as processes (``grouping``: runner.graph.GROUPINGS) and supervise them.
    Nodes are named by their node name (``run(main=...)``); what failed is named by its process."""

    def __init__(self, nodes, domain_id: int, work_dir: Path, python: str = sys.executable,
                 grouping: str = "none", namespace: str = ""):
        from .graph import processes
        self.nodes = nodes
        self.processes = processes(nodes, grouping)
        self.process_of = {n.name: p.name for p in self.processes for n in p.nodes}
        self.domain_id = domain_id
        self.work_dir = Path(work_dir)
        self.work_dir.mkdir(parents=True, exist_ok=True)
        self.env = ros_environment(domain_id, self.work_dir / "ros_log")
        # where the plant says how far the run is (simulated seconds), about once a wall second
        self.progress_file = self.env["RW_FDI_PROGRESS"] = str(self.work_dir / "progress")
        self.python = python
        self.namespace = namespace   # every node's: one spacecraft among others in the same ROS graph
        self.procs = {}

    def start(self):
        clean_zombie_files()   # a killed run's shared-memory files must not stall this one's discovery
        params_file = write_params_file(self.nodes, self.work_dir / "params.yaml", self.namespace)
        for p in self.processes:
            cmd = process_command(p, params_file, self.python, self.namespace)
            log = open(self.work_dir / f"{p.name}.log", "w")
            self.procs[p.name] = subprocess.Popen(cmd, env=self.env, stdout=log, stderr=subprocess.STDOUT,
                                                  stdin=subprocess.DEVNULL, start_new_session=True)
            log.close()
        return self

    def reason_of(self, name: str) -> str:
        code = self.procs[name].returncode
        how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        line = _last_line(self.work_dir / f"{name}.log")
        return f"{name} stopped ({how})" + (f": {line}" if line else "")

    def stop_all(self, last=("recorder",)):
        """Stop everything; the recorder's process last so it can finalise what the others sent."""
        last = {self.process_of.get(n, n) for n in last}
        stop_processes([p for n, p in self.procs.items() if n not in last])
        stop_processes([self.procs[n] for n in last if n in self.procs], grace=10.0)

    def run(self, main: str = "plant", watchdog: float = 600.0, finisher: str | None = "recorder",
            finish_timeout: float = 30.0, progress=None) -> GraphResult:
        """Wait for the process of node ``main`` to end; then for ``finisher``'s; any other essential death
        fails the run. ``progress(simulated_s, duration_s)`` is told how far the plant is, each wall second."""
        t0 = told = time.monotonic()
        essential = {p.name for p in self.processes if p.essential}
        main = self.process_of.get(main, main)
        finisher = self.process_of.get(finisher, finisher) if finisher else None
        try:
            while True:
                time.sleep(0.02)
                if progress and time.monotonic() - told >= 1.0:
                    told = time.monotonic()
                    self._tell(progress)
                main_code = self.procs[main].poll()
                # a clean exit (0) is a node that saw the run end; a missing peer makes the plant time out
                dead = [n for n in essential if n != main and self.procs[n].poll() not in (None, 0, TEARDOWN_HUNG)]
                if dead and (main_code is None or main_code != 0):
                    # a helper died first: that is the reason, not the plant's timeout that follows
                    return self._fail(self.reason_of(dead[0]), t0)
                if main_code is not None:
                    if main_code not in (0, TEARDOWN_HUNG):
                        return self._fail(self.reason_of(main), t0)
                    break
                if time.monotonic() - t0 > watchdog:
                    alive = [n for n, proc in self.procs.items() if proc.poll() is None]
                    return self._fail(f"graph did not finish within {watchdog:g} s (watchdog; still running: "
                                      f"{', '.join(alive) or 'none'})", t0)
            if finisher and finisher in self.procs:
                try:
                    self.procs[finisher].wait(timeout=finish_timeout)
                except subprocess.TimeoutExpired:
                    self._dump_stack(finisher)
                    return self._fail(f"{finisher} did not finish within {finish_timeout:g} s after {main} (where "
                                      f"it was: {self.work_dir / (finisher + '.log')})", t0)
                if self.procs[finisher].returncode not in (0, TEARDOWN_HUNG):
                    return self._fail(self.reason_of(finisher), t0)
            self.stop_all()
            hung = self.teardown_hung()
            note = (f" ({', '.join(hung)}: teardown hung after the work was done, ended by its watchdog; stack in "
                    f"{self.work_dir})") if hung else ""
            return GraphResult(True, "completed" + note, time.monotonic() - t0, self.exit_codes(), self.work_dir)
        except KeyboardInterrupt:
            return self._fail("interrupted", t0)
        finally:
            self.stop_all()

    def _tell(self, progress):
        try:
            simulated, duration = map(float, Path(self.progress_file).read_text().split())
        except (OSError, ValueError):   # not written yet, or being replaced
            return
        progress(simulated, duration)

    def teardown_hung(self) -> list:
        """The nodes that did their work and were ended by their teardown watchdog (a note, not a failure)."""
        return [n for n, p in self.procs.items() if p.returncode == TEARDOWN_HUNG]

    def _dump_stack(self, name: str):
        """Ask a node that does not end where it is: its faulthandler writes every thread's stack to its log."""
        try:
            self.procs[name].send_signal(signal.SIGUSR1)
            time.sleep(0.5)
        except ProcessLookupError:
            pass

    def _fail(self, reason, t0):
        self.stop_all()
        return GraphResult(False, reason, time.monotonic() - t0, self.exit_codes(), self.work_dir)

    def exit_codes(self):
        return {n: p.returncode for n, p in self.procs.items()}


def cleanup(result: GraphResult, keep: bool):
    """Remove a run's log directory unless it is to be kept.

    Parameters
    ----------
    result : GraphResult
        The run's result (its ``log_dir``).
    keep : bool
        Keep the logs.

    Returns
    -------
    None
    """
    if result.log_dir and not keep:
        shutil.rmtree(result.log_dir, ignore_errors=True)
