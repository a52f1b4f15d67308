"""Where the package's data lives: the source tree here, share/ on a ROS 2 install."""
from __future__ import annotations

import os
from pathlib import Path

PACKAGE = "rw_fdi_ros"
# the vehicle flown unless a scenario names one (config/vehicles/maksat.yaml, the thesis' MakSat): its FDI is
# config/fdi itself, another vehicle's config/fdi/vehicles/<name> (core/mission/vehicle.py takes the name from here)
DEFAULT_VEHICLE = "maksat"
_SOURCE_ROOT = Path(__file__).resolve().parents[1]


def install_prefix() -> Path | None:
    """The install prefix when this package runs from a colcon/ament install
    (<prefix>/lib/pythonX.Y/site-packages/rw_fdi_ros), else None (a source tree or an editable
    install).

    Returns
    -------
    Path or None
        The prefix (it holds share/rw_fdi_ros), or None.
    """
    site = _SOURCE_ROOT
    if site.name in ("site-packages", "dist-packages") and site.parent.parent.name == "lib":
        prefix = site.parents[2]
        if (prefix / "share" / PACKAGE).is_dir():
            return prefix
    return None


def installed_executable(name: str) -> Path | None:
    """<prefix>/lib/rw_fdi_ros/<name> of an install: the file `ros2 run rw_fdi_ros <name>` starts.

    Parameters
    ----------
    name : str
        The executable's name.

    Returns
    -------
    Path or None
        The file, or None outside an install or where it does not exist.
    """
    prefix = install_prefix()
    exe = prefix / "lib" / PACKAGE / name if prefix else None
    return exe if exe is not None and exe.is_file() else None


def config_dir() -> Path:
    """config/ of the source tree, else <share>/rw_fdi_ros/config of an ament install.

    Returns
    -------
    Path
        $RW_FDI_CONFIG where set; else the first of the source tree's config/, the install prefix's, the
        ament index's; else the source tree's config/ (which may not exist).
    """
    env = os.environ.get("RW_FDI_CONFIG")
    if env:
        return Path(env)
    local = _SOURCE_ROOT / "config"
    if local.is_dir():
        return local
    prefix = install_prefix()
    if prefix is not None:
        return prefix / "share" / PACKAGE / "config"
    try:
        from ament_index_python.packages import get_package_share_directory
        return Path(get_package_share_directory(PACKAGE)) / "config"
    except Exception:  # no ament index: fall back to the source layout
        return local


def file_name(name: str) -> str:
    """``name`` when it can name one file or folder inside another: no path separator, not hidden, not '.'
    or '..', printable, at most 100 characters (a scenario's or a vehicle's name names its bags and FDI).

    Parameters
    ----------
    name : str
        The name.

    Returns
    -------
    str
        ``name``; ValueError saying what is wrong with it otherwise.
    """
    if not name or len(name) > 100 or name.startswith(".") or any(c in name for c in "/\\") \
            or not name.isprintable():
        raise ValueError(f"{name[:40]!r} cannot name a file: 1 to 100 printable characters, no '/' or '\\', "
                         "not starting with '.'")
    return name


def under(folder, name: str) -> Path:
    """``folder / name``, ``name`` checked by :func:`file_name`: what a name from a file writes stays in ``folder``.

    Parameters
    ----------
    folder : path-like
        The folder.
    name : str
        The entry's name.

    Returns
    -------
    Path
        The entry's path.
    """
    return Path(folder) / file_name(name)


def fdi_dir(method: str = "speed_aware", vehicle: str | None = None) -> Path:
    """The shipped FDI models and thresholds: config/fdi (ours, speed-aware) or config/fdi/thesis, for the
    thesis' vehicle; config/fdi/vehicles/<vehicle> (`rw-fdi defaults --vehicle`) for another shipped one; a
    user's vehicle's FDI directory (what `rw-fdi defaults --vehicle FILE --out DIR` wrote) for itself.

    Parameters
    ----------
    method : str
        The FDI method: 'thesis', or anything else for 'speed_aware'.
    vehicle : str, optional
        The name of the vehicle the run flies, or its FDI directory; None: the thesis' MakSat.

    Returns
    -------
    Path
        The directory.
    """
    base = config_dir() / "fdi"
    if vehicle is not None and Path(vehicle).is_dir():
        base = Path(vehicle)
    elif vehicle is not None and vehicle != DEFAULT_VEHICLE:
        base = under(base / "vehicles", vehicle)
    return base / ("thesis" if method == "thesis" else "")


def thresholds_dir(method: str = "speed_aware", unit_calibration_time: float = 0.0, vehicle: str | None = None) -> Path:
    """The shipped thresholds of ``method``: those of calibrated observers (unit_calibrated/,
    config/fdi/unit_calibrated/README) when they learn their wheel, else the method's own.

    Parameters
    ----------
    method : str
        The FDI method: 'thesis', or anything else for 'speed_aware'.
    unit_calibration_time : float
        Time [s] of each run the observers learn their wheel's unit from; 0: the datasheet wheel.
    vehicle : str, optional
        The name of the vehicle the run flies (:func:`fdi_dir`); None: the thesis' MakSat.

    Returns
    -------
    Path
        ``fdi_dir(method, vehicle)``, or its unit_calibrated/ where ``unit_calibration_time`` > 0.
    """
    base = fdi_dir(method, vehicle)
    return base / "unit_calibrated" if unit_calibration_time > 0 else base


def fastdds_profiles() -> str | None:
    """FASTDDS_DEFAULT_PROFILES_FILE for the graph: the user's own, else config/fastdds.xml (50 ms
    reliable-writer heartbeat: a run's end and paced bag replay wait on acknowledgements).

    Returns
    -------
    str or None
        $FASTDDS_DEFAULT_PROFILES_FILE where set, else config/fastdds.xml's path where it exists, else None.
    """
    profiles = config_dir() / "fastdds.xml"
    return os.environ.get("FASTDDS_DEFAULT_PROFILES_FILE") or (str(profiles) if profiles.is_file() else None)



def shown_path(path, base) -> str:
    """``path`` relative to ``base`` when it lies inside it: a report names no path of the machine that
    made it, so it reads the same wherever the study directory goes.

    Parameters
    ----------
    path : str or Path
        The path to show.
    base : str or Path
        The directory the report belongs to.

    Returns
    -------
    str
        ``path`` relative to ``base`` where inside it; else config/... where inside the shipped config
        directory; else relative to ``base`` through '..'.
    """
    import os
    path, base = Path(path).resolve(), Path(base).resolve()
    for root, shown in ((base, None), (config_dir().resolve(), "config")):   # the study's, the shipped files
        try:
            rel = path.relative_to(root)
            return str(Path(shown, rel) if shown else rel)
        except ValueError:
            pass
    return os.path.relpath(path, base)
