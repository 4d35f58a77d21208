"""``derive simulate SCENE -o DIR``: trajectory.csv, events.csv, impacts.csv,
summary.json, overview.png and motion.gif.

Rows.  ``trajectory.csv`` holds the runtime's ordinary rows: the ends of the solver's
steps, or with ``[run].output_dt`` the uniform grid ``t0, t0 + dt, ...`` read from the
dense output, so its ``t`` column is uniform.  The states just before and just after each
event (impact, contact, lift-off, graze) are in ``events.csv``, with the same columns
after two text columns ``event`` and ``side`` (before, after); ``impacts.csv`` has one row
per impact (t, I, v_n_minus, v_n_plus).  Column names are plain identifiers (``dX_C`` for
X_C'), so ``numpy.genfromtxt(..., names=True)`` and pandas keep them.  Every run writes
the same files, whatever its model: a run with no impacts (a base run, whose face stays
on the plane; a flight that never lands) writes impacts.csv with its header alone, the
columns its plane's impacts would have (a base run's: the rough plane's, as its
hand-over's flight writes them), so a script or a sweep reads one set of files.

A scene that is not one point has every point's position (``X_P1, Y_P1, Z_P1``, ...),
every rotor's angle and rate relative to the body (``psi_1, dpsi_1``, ...) and each body's
kinetic energy (``E_carrier`` with its rotors locked, ``E_P1``, ..., ``E_R1``, ...: a
rotor's spin beyond that) in place of the one point's ``X_P, Y_P, Z_P`` and ``E_point``.

On a rough plane (the ``rough`` model) the trajectory gains the slip of S (``slip_X,
slip_Y, slip_speed``) and the contact ``mode`` (0 flight, 2 sliding, 3 sticking:
abi.MODES), and each impact its tangential impulse, the slip before and after, the work
of its normal impulse and of friction, and ``stage`` (0 S slipped to the end, 1 it
stuck, 2 it re-slid).
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import abi, json_text

from .driver import Result
from .events import event_rows
from .motion import Motion, for_pictures, motion
from .report import summary


CSV_CHUNK = 8192           # rows formatted at a time (memory stays bounded on long runs)


# integer codes (abi.MODES, abi.IMPACT_STAGES, abi.COUPLE_BITS)
CODE_COLUMNS = frozenset({"mode", "stage", "couples"})


def write_csv(path: Path, header: list, rows: np.ndarray, text: dict | None = None,
              progress=None, select: np.ndarray | None = None) -> None:
    """Numbers as Python's shortest repr (they read back bit for bit), the codes of
    :data:`CODE_COLUMNS` as integers; ``text`` columns (name -> list of strings) go first;
    ``select``: the indices of the rows to write (no copy of a big table).  About a
    microsecond a number: ``progress`` (a fraction done) is told after each chunk of
    rows."""
    text = text or {}
    rows = np.asarray(rows, dtype=float)
    n = len(rows) if select is None else len(select)
    line = ",".join(["%s"] * len(text) + ["%d" if h in CODE_COLUMNS else "%r"
                                          for h in header[:rows.shape[1]]]
                    if rows.ndim == 2 else ["%s"] * len(text)) + "\n"
    lead = list(zip(*text.values())) if text else None
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join([*text, *header]) + "\n")
        for a in range(0, n, CSV_CHUNK):
            chunk = (rows[a:a + CSV_CHUNK] if select is None
                     else rows[select[a:a + CSV_CHUNK]]).tolist()
            if lead:
                chunk = [(*lead[a + k], *row) for k, row in enumerate(chunk)]
            fh.write("".join([line % tuple(row) for row in chunk]))
            if progress is not None:
                progress(min(a + CSV_CHUNK, n) / n)


def trajectory_table(result: Result, mo: Motion | None = None) -> tuple[list, np.ndarray]:
    """Every row's columns: ``t``, the states (plain names), the extras asked in
    ``[run].outputs``, then what the pictures use: positions of O and P, the energies and
    the height ``h`` of S, where the model gives them."""
    mo = mo if mo is not None else motion(result)
    header = ["t", *result.state_names]
    cols = [result.t[:, None], result.q]
    for name, value in result.extras.items():
        if name == "omega" and "omega_x" not in result.state_names:
            header += ["omega_x", "omega_y", "omega_z"]
            cols.append(value)
        elif name == "momentum":
            header += ["K_x", "K_y", "K_z", "K_norm"]
            cols += [value["K_body"], value["K_norm"][:, None]]
    b = mo.bodies                       # a scene that is not one point: every body
    if mo.r_O is not None:
        header += ["X_O", "Y_O", "Z_O"]
        cols.append(mo.r_O)
        if b is None:
            header += ["X_P", "Y_P", "Z_P"]
            cols.append(mo.r_P)
        for j, r_P in enumerate(mo.r_points if b is not None else (), start=1):
            header += [f"X_P{j}", f"Y_P{j}", f"Z_P{j}"]
            cols.append(r_P)
    if b is not None:                   # each rotor's angle and rate (relative to the body)
        for k, psi in enumerate(b.psi, start=1):
            header += [f"psi_{k}", f"dpsi_{k}"]
            cols.append(psi[:, :2])
    if mo.T_carrier is not None and b is None:
        header += ["E_carrier", "E_point"]
        cols += [mo.T_carrier[:, None], mo.T_point[:, None]]
    elif mo.T_carrier is not None:      # the carrier (rotors locked), each point, each rotor
        header += ["E_carrier", *(f"E_P{j}" for j in range(1, len(mo.T_points) + 1)),
                   *(f"E_R{k}" for k in range(1, len(mo.T_rotors) + 1))]
        cols += [mo.T_carrier[:, None], mo.T_points.T, mo.T_rotors.T]
    elif mo.T is not None:
        header.append("E_kinetic")
        cols.append(mo.T[:, None])
    if mo.T is not None:
        header += ["E_potential", "E"]
        cols += [mo.U[:, None], mo.E[:, None]]
    if mo.h is not None:
        header.append("h")
        cols.append(mo.h[:, None])
    if result.slip is not None:
        header += ["slip_X", "slip_Y", "slip_speed", "mode"]
        cols += [result.slip, np.hypot(*result.slip.T)[:, None],
                 result.modes[:, None].astype(float)]
    if result.rough and result.couples_on:      # the couples held (1 spin, 2 rolling)
        header.append("couples")
        cols.append(result.couples[:, None].astype(float))
    return header, np.hstack(cols)


def impact_table(result: Result) -> tuple[list, np.ndarray]:
    """impacts.csv: t, I, v_n_minus, v_n_plus; the rough model adds P_X, P_Y (the tangential
    impulse), the slip of S before and after, the work of the normal impulse and of
    friction, and stage."""
    header = ["t", "I", "v_n_minus", "v_n_plus"]
    if result.model == "base":       # a face on a rough plane has none, but the columns
        header += list(result.IMPACT_FRICTION_COLUMNS)     # of its hand-over's flight
        return header, np.zeros((0, len(header)))
    if not result.rough:
        return header, result.impacts
    return header + list(result.IMPACT_FRICTION_COLUMNS), \
        np.hstack([result.impacts, result.impacts_friction])


def split_rows(result: Result) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the trajectory rows (steps, or the output_dt grid) and of the event rows
    (the state just before and just after each event)."""
    kinds = result.row_kind
    step = abi.ROW_KIND["step"]
    return np.flatnonzero(kinds == step), np.flatnonzero(kinds != step)


def event_table(result: Result, header: list, table: np.ndarray) -> tuple[np.ndarray, dict]:
    """The rows of events.csv, two per event of ``Result.events`` in its order (the state
    just before and just after), with their ``event`` and ``side`` labels.  An event with
    no rows of its own (a contact that begins at an impact: the runtime records one pair)
    is given the state after the event it shares the instant with, twice.  On the rough
    plane an ``after`` row's ``mode`` is the event's own (what follows it, as in
    ``Result.events``: flight after an impact that a contact then follows at once), and
    a ``before`` row's the previous event's."""
    pairs = {id(ev): i for i, ev in event_rows(result)}
    after_kind = abi.ROW_KIND["after_event"]

    def after_of(i):                         # a run's ending event has no after row: its
        j = i + 1                            # before row stands for both
        return j if j < len(table) and result.row_kind[j] == after_kind else i
    picked, kinds, sides, modes = [], [], [], []
    last_after = None
    for ev in result.events:
        i = pairs.get(id(ev))
        before, after = (i, after_of(i)) if i is not None else (last_after, last_after)
        if before is None:                   # (no row at all: nothing to show)
            continue
        picked += [before, after]
        kinds += [ev["kind"], ev["kind"]]
        sides += ["before", "after"]
        modes.append(ev.get("mode"))
        last_after = after
    for i, ev in event_rows(result):         # pairs the events list does not name
        if ev["kind"] == "event":
            picked += [i, after_of(i)]
            kinds += ["event", "event"]
            sides += ["before", "after"]
            modes.append(None)
    rows = table[np.array(picked, dtype=int)] if picked else table[:0].copy()
    if result.rough and picked:
        col = header.index("mode")
        for k, mode in enumerate(modes):
            if mode is not None:             # after: the event's; before: the last one's
                rows[2 * k + 1, col] = abi.MODE[mode]
                if k + 1 < len(modes) and kinds[2 * k + 2] != "event":
                    rows[2 * k + 2, col] = abi.MODE[mode]
    return rows, {"event": kinds, "side": sides}


TABLE_FILES = {"csv": ("trajectory.csv", "events.csv", "impacts.csv"), "npz": ("run.npz",)}
FORMATS = tuple(TABLE_FILES)
PICTURE_FILES = ("overview.png", "motion.gif")
SUMMARY_FILE = "summary.json"
# a closed loop's own files (derive.control): the realised law and what the loop did
LOOP_FILES = ("law.csv", "control.json", "control.png")
OUTPUT_NAMES = frozenset(sum(TABLE_FILES.values(), PICTURE_FILES + (SUMMARY_FILE,)
                             + LOOP_FILES))


def write_tables(result: Result, mo: Motion, out: Path, fmt: str = "csv",
                 progress=None) -> list[Path]:
    """trajectory, events and impacts as CSV (default) or one ``.npz`` of named arrays;
    ``progress`` (a fraction done) follows the trajectory's CSV."""
    header, table = trajectory_table(result, mo)
    steps, _ = split_rows(result)
    event_rows_, labels = event_table(result, header, table)
    imp_header, imp = impact_table(result)
    if fmt == "csv":
        paths = [out / name for name in TABLE_FILES["csv"]]
        write_csv(paths[0], header, table, progress=progress, select=steps)
        write_csv(paths[1], header, event_rows_, labels)
        write_csv(paths[2], imp_header, imp)
        return paths
    if fmt == "npz":
        arrays = {f"trajectory/{h}": table[steps, k] for k, h in enumerate(header)}
        arrays.update({f"events/{h}": event_rows_[:, k] for k, h in enumerate(header)})
        arrays.update({f"events/{k}": np.array(v, dtype=str) for k, v in labels.items()})
        arrays.update({f"impacts/{h}": imp[:, k] for k, h in enumerate(imp_header)})
        path = out / TABLE_FILES["npz"][0]
        np.savez_compressed(path, **arrays)
        return [path]
    raise ValueError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")


def write_all(result: Result, out_dir, plot: bool = True, animation: bool = False,
              fmt: str = "csv", progress=None, extra: dict | None = None,
              announce=None) -> list[Path]:
    """Tables, ``overview.png`` (``plot``), ``motion.gif`` (``animation``) and
    ``summary.json`` (last, with the time each part took).  Each file is complete or
    absent: all are written into a hidden folder inside ``out_dir`` and moved into place
    when the last is done, so an interrupted write (Ctrl-C, a full disk, a killed job)
    leaves no half-written table and keeps the files of an earlier run whole.  A finished
    write removes the outputs of an earlier run it did not replace (``OUTPUT_NAMES``:
    another format, plots not asked this time), so the folder holds one run.
    ``progress``: told the fraction of the trajectory's table written (the long part of a
    run with millions of rows); ``announce``: told the name of each later part as it
    begins (the energy balance, each picture: seconds each on a long run).  ``extra``:
    more files, name -> text (or a function that writes the file at the path it is
    given), written with the others (a closed loop's law.csv, control.json and
    control.png)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stage_dir = Path(tempfile.mkdtemp(prefix=".writing-", dir=out))
    try:
        staged = _write_all(result, stage_dir, plot, animation, fmt, progress, announce)
        for name, content in (extra or {}).items():
            if callable(content):                  # a picture: it writes itself
                content(stage_dir / name)
            else:
                (stage_dir / name).write_text(content, encoding="utf-8")
            staged.append(stage_dir / name)
        final = []
        for path in staged:
            os.replace(path, out / path.name)
            final.append(out / path.name)
        # what an earlier run of another scene or format left would pass for this run's
        for name in OUTPUT_NAMES - {p.name for p in final}:
            (out / name).unlink(missing_ok=True)
        return final
    finally:
        shutil.rmtree(stage_dir, ignore_errors=True)


def _write_all(result: Result, out: Path, plot: bool, animation: bool,
               fmt: str, progress=None, announce=None) -> list[Path]:
    announce = announce or (lambda name: None)
    timings = {}
    start = time.perf_counter()
    mo = motion(result)
    written = write_tables(result, mo, out, fmt, progress)
    timings["tables_s"] = time.perf_counter() - start
    trace: list = []           # the balance's share of each flight, for the overview
    announce("summing the energy balance")
    start = time.perf_counter()
    info = summary(result, mo, trace)
    timings["summary_s"] = time.perf_counter() - start
    if plot or animation:
        start = time.perf_counter()
        fine = for_pictures(result)
        mo_fine = mo if fine is result else motion(fine)
        timings["resample_s"] = time.perf_counter() - start
    if plot:
        start = time.perf_counter()
        announce(f"drawing {PICTURE_FILES[0]}")
        from .plots import overview
        written.append(overview(fine, mo_fine, out / PICTURE_FILES[0], steps=result,
                                energy_trace=trace))
        timings["overview_s"] = time.perf_counter() - start
    if animation and mo_fine.r_O is not None:
        start = time.perf_counter()
        announce(f"drawing {PICTURE_FILES[1]}")
        from .animation import write_gif
        written.append(write_gif(fine, mo_fine, out / PICTURE_FILES[1]))
        timings["animation_s"] = time.perf_counter() - start
    info["timings_s"]["outputs"] = timings
    result.timings["outputs"] = timings
    (out / SUMMARY_FILE).write_text(json_text.dumps(info), encoding="utf-8")
    written.append(out / SUMMARY_FILE)
    return written
