"""A recorded run read back as what the judge takes (scoring.metrics): the FDI's series, identification,
health and ground truth of a bag, streamed (no ROS)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.fdi.identification import Identification
from ..core.mission.scenario import Scenario
from ..graph import topics as T
from .metrics import OBSERVERS, Series
from ..core.mission.yaml_text import read_yaml


def fdi_output_topics(plugins=()) -> list:
    """The topics :func:`series_from_bag` reads (read only these: a replay bag holds much more), with those
    of the plug-in observers of slots ``plugins``.

    Returns
    -------
    list of str
        Every observer slot's residual topics (the Elman ones per wheel of any set), threshold and alarm
        topics, then /fdi/identification and /scenario.
    """
    slots = (*OBSERVERS, *plugins)
    outputs = [t for obs in slots for k, t in T.fdi_output_topics(obs).items() if k != "status"]
    return any_wheel_topics("residual", slots) + outputs + [T.IDENTIFICATION, T.SCENARIO]


def any_wheel_topics(kind: str, slots) -> list:
    """The observer output ``kind`` (graph.topics.OBSERVER_OUTPUTS) of every slot of ``slots``: the Elman
    ones per wheel of any set, so that a bag of any wheel set is read whole.

    Parameters
    ----------
    kind : str
        'estimate', 'residual' or 'ripple_bound'.
    slots : sequence of str
        The observer slots.

    Returns
    -------
    list of str
        The topics' names, slot by slot.
    """
    from ..core.physics.wheel_set import ALL_WHEEL_NAMES
    return [T.observer_topic(obs, kind, a) for obs in slots for a in (ALL_WHEEL_NAMES if obs == "elman" else (None,))]


def wheels_of_bag(data) -> tuple:
    """The wheel names of a recorded run: its /scenario's wheel set (a bag from before the redundant wheel:
    the three axis wheels).

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).

    Returns
    -------
    tuple of str
        The wheel set's names, in its order.
    """
    from ..core.mission.plant_choices import PlantChoices
    from ..core.physics.wheel_set import wheel_set
    recorded = (read_yaml(data.scenario_text, "the recorded /scenario") or {}).get("plant") \
        if data.scenario_text else None
    return wheel_set(PlantChoices.from_recorded(recorded).wheel_set).names


def observer_vectors(data, observer: str, kind: str = "residual", wheels=None):
    """(time [s], values (n, wheels)) of one observer's output ``kind`` (residual, ripple_bound, estimate):
    the Elman nodes' per-wheel topics, each carrying its own wheel (or, recorded before the redundant
    wheel, its own axis' component), joined into one.

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).
    observer : str
        The observer slot.
    kind : str
        One of graph.topics.OBSERVER_OUTPUTS.
    wheels : tuple of str, optional
        The run's wheel names; None: :func:`wheels_of_bag`.

    Returns
    -------
    time : ndarray, shape (n,)
        Header stamps [s] (of the first wheel's topic where per wheel, cut to the shortest).
    values : ndarray, shape (n, wheels)
        One column per wheel, in the unit of the topic ([N m] for the three named).
    """
    axes = T.observer_axes(observer)
    if axes == (None,):
        return data.wheel_values(T.observer_topic(observer, kind))
    wheels = wheels or wheels_of_bag(data)
    cols = [data.wheel_values(T.observer_topic(observer, kind, a)) for a in wheels]
    n = min(len(t) for t, _ in cols)
    values = (np.stack([v[:n, i if v.shape[1] == 3 and len(wheels) == 3 else 0] for i, (_, v) in enumerate(cols)],
                       axis=1) if n else np.zeros((0, len(wheels))))
    return cols[0][0][:n], values


def observers_in_bag(data) -> list:
    """The observer slots whose decisions a bag holds (the method's: core/fdi/detection.observers_of).

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).

    Returns
    -------
    list of str
        The slots (of OBSERVERS, in their order) with at least one alarm message.
    """
    return [obs for obs in (*OBSERVERS, *plugin_slots_of(data.types))
            if len(data.wheel_values(T.fdi_output_topics(obs)["alarm"])[0])]


def plugin_slots_of(topics) -> list:
    """The slots of a user's observers (core/fdi/observer_plugin.py) among ``topics`` (names): those with an
    /fdi/<slot>/alarm that is not one of ours."""
    return sorted({t.split("/")[2] for t in topics if t.startswith("/fdi/") and t.endswith("/alarm")
                   and t.count("/") == 3} - set(OBSERVERS))


def series_from_bag(data) -> dict:
    """observer -> Series from a bag holding the isolation node's outputs and the residuals (the
    observers the run had).

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).

    Returns
    -------
    dict of str to Series
        Observer -> time [s] (n,), |residual| [N m], threshold [N m] and alarm (bool), (n, wheels) each.
        ValueError where the bag holds no FDI outputs.
    """
    out = {}
    for obs in observers_in_bag(data):
        topics = T.fdi_output_topics(obs)
        t, alarm = data.wheel_values(topics["alarm"])
        t_c, thr = data.wheel_values(topics["threshold"])
        t_r, res = observer_vectors(data, obs)
        n = min(len(t), len(t_c), len(t_r))
        if n == 0:
            raise ValueError(f"{data.path}: no {obs} FDI outputs")
        # the alarm compares the residual's magnitude (the speed-aware residual is signed)
        out[obs] = Series(t[:n], np.abs(res[:n]), thr[:n], alarm[:n] > 0.5)
    if not out:
        raise ValueError(f"{data.path}: no FDI outputs")
    return out


def identification_from_bag(data) -> dict:
    """axis -> the last /fdi/identification status of that wheel as a dict (message + values), its
    identification read by Identification.from_values and written again (a former kind name reads as the name
    now); wheels never alarmed (or a bag without the topic) are left out.

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).

    Returns
    -------
    dict of str to dict of str to str
        Wheel (its hardware_id's last part) -> message and the status' values (fault_kind, fault_size, ...).
    """
    last = data.last(T.IDENTIFICATION)
    if last is None:
        return {}
    out = {}
    for status in last.status:
        values = {kv.key: kv.value for kv in status.values}
        found = Identification.from_values(values)
        if found is not None:
            out[status.hardware_id.rsplit("_", 1)[-1]] = {"message": status.message, **values, **found.values()}
    return out


def verdict_messages(data) -> list:
    """A read bag's /diagnostics with only the FDI's verdicts: FDIR's state of the wheels (the other statuses
    on the topic) left out, and the messages left without a status dropped.

    Parameters
    ----------
    data : BagData
        The bag, read (storage.bag.read_bag) with /diagnostics among its topics.

    Returns
    -------
    list of (int, DiagnosticArray)
        (log time [ns], the message with its verdict statuses only), in log-time order, as ``data.topic``.
    """
    import dataclasses
    out = []
    for log_time, msg in data.topic(T.DIAGNOSTICS):
        statuses = T.verdict_statuses(msg)
        if statuses:
            out.append((log_time, dataclasses.replace(msg, status=statuses)))
    return out


def health_topics(slots=()) -> list:
    """The statuses :func:`health_from_bag` reads: /diagnostics and each observer's status.

    Parameters
    ----------
    slots : iterable of str
        Plug-in observers' slots, read beside ours.

    Returns
    -------
    list of str
        /diagnostics, then every observer slot's status topic.
    """
    return [T.DIAGNOSTICS] + [T.fdi_output_topics(obs)["status"] for obs in (*T.OBSERVERS, *slots)]


def diagnostics_alarms(path):
    """(time [s] (n,), faulty (n, wheels) flags) of a bag's /diagnostics: a wheel whose verdict status is ERROR
    (the verdict users read: the decision observer's alarm, latched; FDIR's state of the wheels, on the same
    topic, left out), streamed; empty arrays without it. The
    wheels are those of the first message, in its order (the wheel set's).

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.

    Returns
    -------
    time : ndarray of float, shape (n,)
        Header stamps [s], ascending; messages lacking one of the wheels left out.
    faulty : ndarray of bool, shape (n, wheels)
        Whether each wheel's status is ERROR.
    """
    times, rows, joints = [], [], None
    for _, t, msg in _status_arrays(path, [T.DIAGNOSTICS]):
        statuses = T.verdict_statuses(msg)
        if not statuses:
            continue
        levels = {s.hardware_id: s.level for s in statuses}
        joints = joints or [s.hardware_id for s in statuses]
        wheels = [levels.get(j) for j in joints]
        if None in wheels:
            continue
        times.append(t)
        rows.append([level == 2 for level in wheels])   # DiagnosticStatus.ERROR
    order = np.argsort(times, kind="stable")
    return np.asarray(times, float)[order], np.asarray(rows, bool).reshape(len(times), len(joints or ()))[order]


def _status_arrays(path, topics):
    """(topic, header stamp [s], DiagnosticArray) of a bag's ``topics``, streamed in file order."""
    from ..storage.bag import iter_messages, typestore
    store = typestore()
    for topic, _, raw in iter_messages(path, topics):
        msg = store.deserialize_cdr(raw, "diagnostic_msgs/msg/DiagnosticArray")
        yield topic, msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, msg


def health_from_bag(path) -> dict:
    """What the FDI said about itself over a run, streamed from its statuses (memory does not grow):
    per status topic and wheel, the samples it could not judge (STALE) and those whose input stream
    had trouble (WARN: gaps, dropped duplicates or late samples), each with the first time and message.
    A wheel with neither is left out.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.

    Returns
    -------
    dict
        Status topic -> wheel -> kind ('cannot_judge', 'input_trouble') -> samples (int), first_s (the first
        such message's header stamp [s], in file order) and message (str).
    """
    from ..storage.bag import BagError, message_counts
    out = {}
    try:   # a plug-in's status too: an observer that went blind is named, not only those that decide
        topics = message_counts(path if Path(path).is_dir() else Path(path).parent)
    except BagError:
        topics = {}
    slots = [t.split("/")[2] for t in topics if t.startswith("/fdi/") and t.endswith("/status")
             and t.count("/") == 3 and t.split("/")[2] not in T.OBSERVERS]
    for topic, t, msg in _status_arrays(path, health_topics(slots)):
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}   # the isolation node's judged / input values
            kinds = (["cannot_judge"] if values.get("judged") == "false" else []) + \
                (["input_trouble"] if "input" in values else [])
            for kind in kinds:
                row = out.setdefault(topic, {}).setdefault(s.hardware_id.rsplit("_", 1)[-1], {})
                seen = row.setdefault(kind, {"samples": 0, "first_s": t, "message": s.message})
                seen["samples"] += 1
    return out


def scenario_of(data) -> Scenario:
    """The ground truth of a recorded run, from its /scenario.

    Parameters
    ----------
    data : BagData or BagSeries
        The bag, read (storage.bag.read_bag or read_series).

    Returns
    -------
    Scenario
        The parsed scenario (ValueError where the bag has no /scenario).
    """
    from ..core.mission.scenario import parse_scenario
    if not data.scenario_text:
        raise ValueError(f"{data.path}: no /scenario message (no ground truth)")
    return parse_scenario(data.scenario_text, origin=f"{data.path}:/scenario")
