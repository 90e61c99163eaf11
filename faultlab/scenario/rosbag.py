"""A test case as a ROS 2 bag (written and read with the ``rosbags`` library, no ROS installation needed).

Step ``t`` of a case (:class:`~faultlab.scenario.model.Scenario`; 0-based) happens at time
``(t + 1) * STEP_S`` (:data:`faultlab.scenario.tum.STEP_S`, 1 s); the start pose is stamped 0.  Topics (frame
``map`` for ground truth, ``odom`` for odometry, ``base_link`` for the robot):

==============================  ==================================  ==============================================
topic                           type                                content
==============================  ==================================  ==============================================
``/odom``                       ``nav_msgs/msg/Odometry``           one per step: ``twist.twist.linear.x`` = ``v``
                                                                    (m per step), ``twist.twist.angular.z`` =
                                                                    ``omega`` (rad per step) -- the measured
                                                                    control fed to the SLAM; ``pose.pose``: the
                                                                    odometry pose (measured controls integrated
                                                                    from the start pose, drive then turn)
``/observations``               ``faultlab_msgs/msg/RangeBearing``  one per step (also when empty): ``ids``,
                                ``Array``                           ``ranges`` (m), ``bearings`` (rad, relative to
                                                                    the heading), observed after the step's motion
``/ground_truth/pose``          ``geometry_msgs/msg/PoseStamped``   the true pose: one at time 0, one per step
``/ground_truth/landmarks``     ``faultlab_msgs/msg/LandmarkMap``   one message at time 0: ``ids``, ``x``, ``y`` (m)
==============================  ==================================  ==============================================

Headings are quaternions about z (``qz = sin(theta / 2)``, ``qw = cos(theta / 2)``); z is 0.  The two
custom message types (:data:`MESSAGE_DEFINITIONS`) are stored in the bag, so ``rosbags``'
``AnyReader`` reads it as is; ROS 2 tools need them built in a ``faultlab_msgs`` package.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from faultlab.errors import ScenarioError
from faultlab.scenario.tum import STEP_S, odometry_poses, step_times

__all__ = ["TOPICS", "MESSAGE_DEFINITIONS", "BagContents", "write_bag", "read_bag"]

_NS = 1_000_000_000

#: Topic -> message type.
TOPICS = {
    "/odom": "nav_msgs/msg/Odometry",
    "/observations": "faultlab_msgs/msg/RangeBearingArray",
    "/ground_truth/pose": "geometry_msgs/msg/PoseStamped",
    "/ground_truth/landmarks": "faultlab_msgs/msg/LandmarkMap",
}

#: The custom message types (ROS 2 .msg syntax).
MESSAGE_DEFINITIONS = {
    "faultlab_msgs/msg/RangeBearingArray": (
        "# Range-bearing observations of one time step (known correspondences).\n"
        "std_msgs/Header header\n"
        "int64[] ids\n"
        "float64[] ranges\n"
        "float64[] bearings\n"),
    "faultlab_msgs/msg/LandmarkMap": (
        "# A landmark map: landmark ids[i] at (x[i], y[i]), m.\n"
        "std_msgs/Header header\n"
        "int64[] ids\n"
        "float64[] x\n"
        "float64[] y\n"),
}


def _typestore():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = {}
    for name, text in MESSAGE_DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


@dataclass(frozen=True, eq=False)
class BagContents:
    """What :func:`read_bag` found: the arrays of a :class:`~faultlab.scenario.model.Scenario`.

    Attributes
    ----------
    controls : ndarray, shape (T, 2)
    odometry : ndarray, shape (T, 3)
        The odometry poses after each step (headings from the quaternions).
    obs_offsets : ndarray, shape (T + 1,)
    obs_range, obs_bearing : ndarray, shape (M,)
    obs_ids : ndarray, shape (M,), int64
    true_poses : ndarray, shape (T + 1, 3)
    landmark_ids : ndarray, shape (L,), int64
    landmarks : ndarray, shape (L, 2)
    stamps : dict of str to ndarray of int64
        Per topic, the receive times of its messages, ns.
    """

    controls: np.ndarray
    odometry: np.ndarray
    obs_offsets: np.ndarray
    obs_range: np.ndarray
    obs_bearing: np.ndarray
    obs_ids: np.ndarray
    true_poses: np.ndarray
    landmark_ids: np.ndarray
    landmarks: np.ndarray
    stamps: dict


def _stamp(store, t_ns: int):
    Time = store.types["builtin_interfaces/msg/Time"]
    return Time(sec=int(t_ns // _NS), nanosec=int(t_ns % _NS))


def _header(store, t_ns: int, frame: str):
    return store.types["std_msgs/msg/Header"](stamp=_stamp(store, t_ns), frame_id=frame)


def _pose(store, x: float, y: float, theta: float):
    T = store.types
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=float(np.sin(theta / 2)),
                                                     w=float(np.cos(theta / 2))))


def write_bag(scenario, path: str | Path) -> Path:
    """Write ``scenario`` as a ROS 2 bag (sqlite3 storage) in the new directory ``path`` (module docstring).

    Raises
    ------
    ScenarioError
        If ``path`` exists (a bag is never overwritten).
    """
    from rosbags.rosbag2 import Writer

    path = Path(path)
    if path.exists():
        raise ScenarioError(f"ROS 2 bag {path}: already exists; choose another output directory")
    store = _typestore()
    T = store.types
    zeros = np.zeros(36)
    odo = odometry_poses(scenario.start_pose, scenario.controls)
    times = np.round(step_times(scenario.n_steps) * _NS).astype(np.int64)
    path.parent.mkdir(parents=True, exist_ok=True)
    with Writer(path, version=9) as writer:
        conn = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in TOPICS.items()}

        def put(topic: str, t_ns: int, message) -> None:
            writer.write(conn[topic], int(t_ns), bytes(store.serialize_cdr(message, TOPICS[topic])))

        landmarks = np.asarray(scenario.landmarks, dtype=float)
        put("/ground_truth/landmarks", 0, T["faultlab_msgs/msg/LandmarkMap"](
            header=_header(store, 0, "map"), ids=np.asarray(scenario.landmark_ids, dtype=np.int64),
            x=landmarks[:, 0].copy(), y=landmarks[:, 1].copy()))
        for t in range(scenario.n_steps + 1):
            put("/ground_truth/pose", times[t], T["geometry_msgs/msg/PoseStamped"](
                header=_header(store, times[t], "map"), pose=_pose(store, *scenario.true_poses[t])))
        Vector3 = T["geometry_msgs/msg/Vector3"]
        for t in range(scenario.n_steps):
            v, omega = (float(c) for c in scenario.controls[t])
            stamp = times[t + 1]
            twist = T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=Vector3(x=v / STEP_S, y=0.0, z=0.0),
                                                   angular=Vector3(x=0.0, y=0.0, z=omega / STEP_S)),
                covariance=zeros.copy())
            put("/odom", stamp, T["nav_msgs/msg/Odometry"](
                header=_header(store, stamp, "odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(store, *odo[t + 1]),
                                                              covariance=zeros.copy()),
                twist=twist))
            a, b = int(scenario.obs_offsets[t]), int(scenario.obs_offsets[t + 1])
            put("/observations", stamp, T["faultlab_msgs/msg/RangeBearingArray"](
                header=_header(store, stamp, "base_link"),
                ids=np.asarray(scenario.obs_ids[a:b], dtype=np.int64).copy(),
                ranges=np.asarray(scenario.obs_range[a:b], dtype=float).copy(),
                bearings=np.asarray(scenario.obs_bearing[a:b], dtype=float).copy()))
    return path


def _yaw(q) -> float:
    return 2.0 * float(np.arctan2(q.z, q.w))


def read_bag(path: str | Path) -> BagContents:
    """Read a bag written by :func:`write_bag` back into arrays (with ``rosbags``' ``AnyReader``)."""
    from rosbags.highlevel import AnyReader

    path = Path(path)
    if not path.is_dir():
        raise ScenarioError(f"ROS 2 bag {path}: not a directory")
    messages: dict[str, list] = {topic: [] for topic in TOPICS}
    stamps: dict[str, list] = {topic: [] for topic in TOPICS}
    with AnyReader([path], default_typestore=_typestore()) as reader:
        wanted = [c for c in reader.connections if c.topic in TOPICS]
        for connection, t_ns, raw in reader.messages(connections=wanted):
            messages[connection.topic].append(reader.deserialize(raw, connection.msgtype))
            stamps[connection.topic].append(t_ns)
    odom, obs = messages["/odom"], messages["/observations"]
    truth, lm = messages["/ground_truth/pose"], messages["/ground_truth/landmarks"]
    if len(lm) != 1 or len(odom) != len(obs) or len(truth) != len(odom) + 1:
        raise ScenarioError(f"ROS 2 bag {path}: not a faultlab case (expected one landmark map, as many "
                            f"observation as odometry messages and one more true pose)")
    counts = np.array([len(m.ids) for m in obs], dtype=np.int64)

    def flat(field: str, dtype) -> np.ndarray:
        parts = [np.asarray(getattr(m, field), dtype=dtype) for m in obs]
        return np.concatenate(parts) if parts else np.empty(0, dtype=dtype)

    return BagContents(
        controls=np.array([[m.twist.twist.linear.x * STEP_S, m.twist.twist.angular.z * STEP_S] for m in odom],
                          dtype=float).reshape(-1, 2),
        odometry=np.array([[m.pose.pose.position.x, m.pose.pose.position.y, _yaw(m.pose.pose.orientation)]
                           for m in odom], dtype=float).reshape(-1, 3),
        obs_offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        obs_range=flat("ranges", float), obs_bearing=flat("bearings", float), obs_ids=flat("ids", np.int64),
        true_poses=np.array([[m.pose.position.x, m.pose.position.y, _yaw(m.pose.orientation)] for m in truth],
                            dtype=float),
        landmark_ids=np.asarray(lm[0].ids, dtype=np.int64),
        landmarks=np.stack([np.asarray(lm[0].x, dtype=float), np.asarray(lm[0].y, dtype=float)], axis=1),
        stamps={k: np.asarray(v, dtype=np.int64) for k, v in stamps.items()})
