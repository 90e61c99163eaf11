"""The test case: a landmark map, the true path and the sensor trace fed to the SLAM."""

from __future__ import annotations

import errno
import hashlib
import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from faultlab.errors import InvalidCaseError, NoGroundTruthError, ScenarioError
from faultlab.space.case import CaseSpec

__all__ = ["Scenario", "save_scenario", "load_scenario"]

_ARRAYS = ("landmarks", "landmark_ids", "true_poses", "controls", "obs_offsets", "obs_range",
           "obs_bearing", "obs_ids")
FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class Scenario:
    """One test case (Sec. IV, Fig. 2).

    Step ``t`` (0-based, ``t < n_steps``) is: apply control ``controls[t]``
    (drive ``v`` along the heading, then turn by ``omega``: FastSLAM's motion
    model with dt = 1), then observe from the new pose ``true_poses[t + 1]``.
    Observations of step ``t`` are the slice ``obs_offsets[t]:obs_offsets[t+1]``
    of the flat ``obs_*`` arrays (CSR layout).

    Attributes
    ----------
    case : CaseSpec
        Parameter values and classes the scenario was generated from.
    seed : int or None
        Entropy of the SeedSequence that generated it (None if unknown).
    landmarks : ndarray, shape (L, 2)
        Ground-truth landmark positions, m.
    landmark_ids : ndarray, shape (L,), int64
        Unique landmark ids.
    true_poses : ndarray, shape (T + 1, 3)
        True vehicle poses (x, y, theta) before step 0 and after every step.
    controls : ndarray, shape (T, 2)
        Measured controls (v, omega) with noise, bias and rotation error, as fed to the SLAM.
    obs_offsets : ndarray, shape (T + 1,), int64
        CSR offsets into the observation arrays; ``obs_offsets[0] == 0``.
    obs_range, obs_bearing : ndarray, shape (M,)
        Measured range (m) and bearing (rad, relative to the heading).
    obs_ids : ndarray, shape (M,), int64
        Landmark id of each observation (known correspondences).  Always the true ids, also for
        a SLAM with unknown data association: the driver hides them from such a SLAM
        (:mod:`faultlab.slam.protocol`, "Data association"), so one file serves both kinds.
    meta : dict
        JSON-serialisable extras (generator settings, SI config, ...).
    """

    case: CaseSpec
    seed: int | None
    landmarks: np.ndarray
    landmark_ids: np.ndarray
    true_poses: np.ndarray
    controls: np.ndarray
    obs_offsets: np.ndarray
    obs_range: np.ndarray
    obs_bearing: np.ndarray
    obs_ids: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def n_steps(self) -> int:
        """Number of steps T (active plus inactive)."""
        return int(self.controls.shape[0])

    @property
    def fov_bug(self) -> bool:
        """Whether the scenario was generated with the replication package's field-of-view defect.

        Read from ``meta["config"]["fov_bug"]``; False for scenarios that do not record it.
        """
        return bool(self.meta.get("config", {}).get("fov_bug", False))

    @property
    def has_truth(self) -> bool:
        """Whether the ground truth (landmark positions, poses after the start) is known.

        False for a real data set (``meta["ground_truth"] = False``): its ``landmarks`` are NaN (the
        observed ids are known, their positions are not) and ``true_poses`` is NaN after the known start
        pose.  Metrics and oracles that need the truth raise :class:`~faultlab.errors.NoGroundTruthError`
        (:meth:`require_truth`) instead of computing NaN.
        """
        return bool(self.meta.get("ground_truth", True))

    def require_truth(self, what: str) -> None:
        """Raise :class:`~faultlab.errors.NoGroundTruthError` naming ``what`` unless the truth is known."""
        if not self.has_truth:
            name = self.meta.get("dataset", "this scenario")
            raise NoGroundTruthError(f"{what} needs the ground truth, and {name} has none (a real data set: "
                                     f"judge it by the oracles that need no truth)")

    @property
    def start_pose(self) -> np.ndarray:
        """The known initial pose, shape (3,)."""
        return self.true_poses[0].copy()

    def observations(self, t: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(range, bearing, ids) observed in step ``t``, each shape (k,)."""
        a, b = int(self.obs_offsets[t]), int(self.obs_offsets[t + 1])
        return self.obs_range[a:b], self.obs_bearing[a:b], self.obs_ids[a:b]

    def validate(self) -> None:
        """Raise :class:`ScenarioError` if arrays are inconsistent."""
        L = self.landmarks.shape[0]
        T = self.controls.shape[0]
        checks = [
            (self.landmarks.ndim == 2 and self.landmarks.shape[1] == 2, "landmarks must have shape (L, 2)"),
            (self.landmark_ids.shape == (L,), "landmark_ids must have shape (L,)"),
            (len(np.unique(self.landmark_ids)) == L, "landmark ids must be unique"),
            (self.true_poses.shape == (T + 1, 3), "true_poses must have shape (T + 1, 3)"),
            (self.controls.ndim == 2 and self.controls.shape[1] == 2, "controls must have shape (T, 2)"),
            (self.obs_offsets.shape == (T + 1,), "obs_offsets must have shape (T + 1,)"),
            (self.obs_offsets[0] == 0 and bool(np.all(np.diff(self.obs_offsets) >= 0)),
             "obs_offsets must start at 0 and be non-decreasing"),
        ]
        M = int(self.obs_offsets[-1]) if T + 1 == self.obs_offsets.shape[0] else -1
        checks += [
            (self.obs_range.shape == (M,) and self.obs_bearing.shape == (M,) and self.obs_ids.shape == (M,),
             "obs_range, obs_bearing and obs_ids must have shape (obs_offsets[-1],)"),
        ]
        if not self.has_truth and T + 1 == self.true_poses.shape[0]:
            checks += [
                (bool(np.all(np.isfinite(self.true_poses[0]))), "a scenario without ground truth still has a "
                                                                 "finite start pose"),
                (bool(np.all(np.isnan(self.true_poses[1:]))) and bool(np.all(np.isnan(self.landmarks))),
                 "a scenario without ground truth has NaN landmarks and NaN poses after the start"),
            ]
        for ok, msg in checks:
            if not ok:
                raise ScenarioError(msg)


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` as an uncompressed ``.npz`` that :func:`numpy.load` reads, byte for byte
    the same for the same arrays (``numpy.savez`` stamps every member with the current time)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as zf:
        for name, array in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asanyarray(array), allow_pickle=False)


def _digest(data: bytes) -> str:
    return hashlib.blake2b(data, digest_size=16).hexdigest()


def _meta_checksum(meta: dict) -> str:
    """Checksum of a case's ``.json`` content (every key but ``checksum``, canonical JSON)."""
    body = {k: v for k, v in meta.items() if k != "checksum"}
    return _digest(json.dumps(body, sort_keys=True, separators=(",", ":")).encode())


def save_scenario(scenario: Scenario, path: str | Path) -> Path:
    """Save losslessly as ``<path>.npz`` (arrays) plus ``<path>.json`` (case, seed, meta, checksums).

    Returns the ``.npz`` path.  Both files are written to a temporary name and
    renamed, so an interrupted save never leaves a half-written case.  The ``.json`` records a
    BLAKE2b digest of the ``.npz`` file's bytes (``npz_blake2b``) and of its own content
    (``checksum``); :func:`load_scenario` verifies both.

    Raises
    ------
    ScenarioError
        The files cannot be written (e.g. the disk is full); no partial file is left.
    """
    base = Path(path)
    if base.suffix in (".npz", ".json"):
        base = base.with_suffix("")
    npz, js = base.with_name(base.name + ".npz"), base.with_name(base.name + ".json")
    tmp_npz, tmp_js = npz.with_name(npz.name + ".tmp.npz"), js.with_name(js.name + ".tmp")
    try:
        base.parent.mkdir(parents=True, exist_ok=True)
        _write_npz(tmp_npz, {k: getattr(scenario, k) for k in _ARRAYS})
        meta = {"format": FORMAT_VERSION, "case": scenario.case.to_dict(), "seed": scenario.seed,
                "meta": scenario.meta, "npz_blake2b": _digest(tmp_npz.read_bytes())}
        meta["checksum"] = _meta_checksum(meta)
        tmp_js.write_text(json.dumps(meta, indent=1, sort_keys=True))
        tmp_npz.replace(npz)
        tmp_js.replace(js)
    except OSError as exc:
        for tmp in (tmp_npz, tmp_js):
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass
        reason = "the disk is full" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise ScenarioError(f"test case {base} cannot be written ({reason})") from exc
    return npz


def load_scenario(path: str | Path) -> Scenario:
    """Load a case written by :func:`save_scenario` (``path`` with or without suffix).

    Verifies the checksums of both files when the ``.json`` has them (cases saved before
    checksums existed load without).

    Raises
    ------
    ScenarioError
        A file is missing, truncated, damaged (checksum mismatch) or not a test case;
        :class:`~faultlab.errors.InvalidCaseError` if its files are intact but its content is not a
        valid case (inconsistent shapes, NaN or infinite values).
    """
    base = Path(path)
    if base.suffix in (".npz", ".json"):
        base = base.with_suffix("")
    npz, js = base.with_name(base.name + ".npz"), base.with_name(base.name + ".json")
    try:
        meta = json.loads(js.read_text())
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
        if meta.get("format") != FORMAT_VERSION:
            raise ScenarioError(f"test case {js}: unsupported format {meta.get('format')!r}")
        if "checksum" in meta and meta["checksum"] != _meta_checksum(meta):
            raise ScenarioError(f"test case {js} is damaged (its content does not match its checksum)")
        if "npz_blake2b" in meta and _digest(npz.read_bytes()) != meta["npz_blake2b"]:
            raise ScenarioError(f"test case {npz} is damaged (its bytes do not match the checksum in {js.name})")
        with np.load(npz, allow_pickle=False) as data:
            arrays = {k: data[k] for k in _ARRAYS}
    except ScenarioError:
        raise
    except FileNotFoundError as exc:
        raise ScenarioError(f"test case {base}: missing file {exc.filename}") from exc
    except (KeyError, ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise ScenarioError(f"test case {base}: unreadable ({type(exc).__name__}: {exc})") from exc
    try:
        sc = Scenario(case=CaseSpec.from_dict(meta["case"]), seed=meta.get("seed"), meta=meta.get("meta", {}),
                      **arrays)
    except (KeyError, TypeError, ValueError) as exc:
        raise ScenarioError(f"test case {js}: unreadable ({type(exc).__name__}: {exc})") from exc
    try:
        sc.validate()
        _check_finite(sc)
    except ScenarioError as exc:
        raise InvalidCaseError(f"test case {npz}: {exc} (its checksums match: it was saved so; "
                               f"regenerate it, e.g. with --force-new)") from None
    return sc


def _check_finite(sc: Scenario) -> None:
    """ScenarioError naming the first array of a saved case that holds a NaN or an infinity.

    A case without ground truth has NaN landmarks and poses after the start by design (:meth:`Scenario.validate`
    checks that pattern); its start pose and measurements must still be finite.
    """
    truth = ("landmarks", "true_poses") if sc.has_truth else ()
    for name in (*truth, "controls", "obs_range", "obs_bearing"):
        values = getattr(sc, name)
        bad = ~np.isfinite(values)
        if bad.any():
            first = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ScenarioError(f"{name} holds {int(bad.sum())} non-finite value(s), the first "
                                f"{values[first]} at index {first if len(first) > 1 else first[0]}")
