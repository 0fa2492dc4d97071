"""Serial arms from URDF files, parsed by ``yourdfpy`` (optional extra ``armpath[urdf]``).

The chain runs from the root link to the tool link (default: the deepest link that no
gripper's finger joint carries, see :func:`_default_tip`). Fixed joints fold into the next
joint's placement (or the tool), ``continuous`` joints are unlimited revolute joints, and
URDF metres become mm. Collision links are the chain's physical skeleton
(:func:`~armpath.model.skeleton.physical_links`); the URDF's own collision shapes are not read,
so their radii are ``link_radii_mm`` (default 0).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from armpath.errors import InvalidInputError
from armpath.model.serial_arm import (
    Joint,
    JointKind,
    SerialArm,
    check_length,
    check_turns,
    default_home,
)
from armpath.model.skeleton import link_radii, physical_links

_M_TO_MM = 1000.0


def _check_well_formed(path: Path) -> None:
    """Refuse a file that is not well-formed XML with a ``<robot>`` root, in one line naming
    where it breaks (a truncated file): yourdfpy would print its XML parser's complaint and
    retry with a forgiving parser, then fail on what that made of the rest."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        line, column = exc.position
        raise InvalidInputError(
            f"URDF {path.name!r} is not well-formed XML: line {line}, column {column + 1} "
            f"({str(exc).split(':')[0]})"
        ) from None
    except OSError as exc:
        raise InvalidInputError(f"URDF {path.name!r} cannot be read: {exc.strerror}") from None
    if root.tag != "robot":
        raise InvalidInputError(
            f"URDF {path.name!r}: the root element is <{root.tag}>, not <robot>"
        )


#: The longest chain (the joint origins' offsets added up, m) a URDF may give: 100 m is far
#: beyond any arm's, and a file written in mm (a 290 mm link as 290) gives hundreds of metres.
MAX_CHAIN_M = 100.0


def _check_limit_given(p: Path, uj: Any) -> None:
    """A revolute or prismatic joint's ``<limit>`` gives its range: one without (ROS's parser
    refuses the file), or without its lower or its upper (ROS reads a missing side as 0; both
    missing: the joint locked), is refused, rather than taken as unlimited on that side."""
    if uj.limit is None:
        raise InvalidInputError(
            f"URDF {p.name!r}: joint {uj.name!r} is {uj.type} but has no <limit> (ROS refuses "
            "such a file); give its lower and upper limits, or make it continuous"
        )
    if uj.limit.lower is None and uj.limit.upper is None:
        raise InvalidInputError(
            f"URDF {p.name!r}: joint {uj.name!r}'s <limit> gives no lower or upper (ROS reads "
            "both as 0, the joint locked); give them, or make the joint continuous"
        )
    if uj.limit.lower is None or uj.limit.upper is None:
        given, missing = ("upper", "lower") if uj.limit.lower is None else ("lower", "upper")
        raise InvalidInputError(
            f"URDF {p.name!r}: joint {uj.name!r}'s <limit> gives its {given} only (ROS reads "
            f"the {missing} as 0); give both"
        )


#: Words that mark a joint of a URDF as a gripper's finger rather than the arm's: in any
#: joint's name (a finger fixed in place counts too: Kinova's Jaco), and ``gripper`` in a
#: moving joint's (the SO-100's ``gripper``, the Z1's ``jointGripper``; Baxter's fixed
#: ``left_gripper_base_joint`` carries the hand).
_FINGER_WORDS = ("finger", "jaw")
_MOVING_FINGER_WORDS = ("gripper",)


def _mimics(joint: Any) -> bool:
    """Whether a URDF joint mimics another (moves with it, not on its own)."""
    return getattr(joint, "mimic", None) is not None


def _is_finger_named(joint: Any) -> bool:
    """Whether a URDF joint is named or tagged as a gripper's finger's (:data:`_FINGER_WORDS`,
    or mimicking another: a gripper's second finger, as Panda's and Talos's)."""
    name = str(joint.name).lower()
    if any(w in name for w in _FINGER_WORDS) or _mimics(joint):
        return True
    return joint.type != "fixed" and any(w in name for w in _MOVING_FINGER_WORDS)


def _moves(joint: Any) -> bool:
    """Whether a URDF joint moves on its own (not fixed, not mimicking another)."""
    return bool(joint.type != "fixed" and not _mimics(joint))


def _hands(
    links: list[str],
    children: dict[str, list[Any]],
    joints_by_child: dict[str, Any],
    depth: Callable[[str], int],
    moves_beyond: dict[str, bool],
) -> set[str]:
    """The links that are a hand's palm by the tree's shape, whatever the joints are named
    (Tiago's hand: thumb, index, middle, ...): two or more chains that move leave the link,
    none of them branches again, and the link is carried by more moving joints than the
    longest of them has (an arm then its fingers; not a dual-arm torso, nor a hand alone)."""
    carried: dict[str, int] = {}
    for link in sorted(links, key=depth):
        joint = joints_by_child.get(link)
        carried[link] = 0 if joint is None else carried[joint.parent] + _moves(joint)
    longest: dict[str, int] = {}  # the most moving joints on a path below each link
    forks: dict[str, bool] = {}  # whether the moving tree below each link branches
    hands: set[str] = set()
    for link in sorted(links, key=depth, reverse=True):
        chains = [j for j in children.get(link, []) if _moves(j) or moves_beyond[j.child]]
        longest[link] = max((_moves(j) + longest[j.child] for j in chains), default=0)
        forks[link] = len(chains) >= 2 or any(forks[j.child] for j in chains)
        if (
            len(chains) >= 2
            and not any(forks[j.child] for j in chains)
            and carried[link] > longest[link]
        ):
            hands.add(link)
    return hands


def _default_tip(
    links: list[str], joints_by_child: dict[str, Any], depth: Callable[[str], int]
) -> str:
    """The tool link when none is named: the deepest link (the first of the file's order
    among the deepest) whose chain passes no finger joint, so that a gripper's finger is not
    taken for the arm's last joint (the SO-100's deepest leaf is its jaw, behind the gripper's
    joint: its arm is the five joints to the ``gripper`` link); the deepest leaf where every
    chain passes one. A finger joint is named or tagged as one (:func:`_is_finger_named`) and
    carries no joint that moves on its own (a mimic joint inside an arm's chain is the arm's,
    and refused as such), or leaves a palm towards a joint that moves (:func:`_hands`: Tiago's
    hand, whose fingers are named thumb, index, middle, ...; its tool is the palm's
    ``hand_grasping_frame``)."""
    children: dict[str, list[Any]] = {}
    for j in joints_by_child.values():
        children.setdefault(j.parent, []).append(j)

    # whether a joint that moves on its own lies beyond each link: deepest links first
    moves_beyond: dict[str, bool] = {}
    for link in sorted(links, key=depth, reverse=True):
        moves_beyond[link] = any(_moves(j) or moves_beyond[j.child] for j in children.get(link, []))

    hands = _hands(links, children, joints_by_child, depth, moves_beyond)

    def through_finger(link: str) -> bool:
        while link in joints_by_child:
            joint = joints_by_child[link]
            if _is_finger_named(joint) and not moves_beyond[joint.child]:
                return True
            if joint.parent in hands and (_moves(joint) or moves_beyond[joint.child]):
                return True
            link = joint.parent
        return False

    plain = [name for name in links if not through_finger(name)]
    if len(plain) > 1:  # more than the root
        return str(max(plain, key=depth))
    return str(max((name for name in links if name not in children), key=depth))


def arm_from_urdf(
    path: str | Path,
    tip_link: str | None = None,
    *,
    link_radii_mm: float | Sequence[float] = 0.0,
) -> SerialArm:
    """Load the serial chain of a URDF (root link to ``tip_link``, default the deepest link
    not carried by a gripper's finger joint: :func:`_default_tip`).

    The arm is named after the robot and the tip link, ``"ur5 [tool0]"``, so every output says
    which link is the tool.

    ``link_radii_mm``: the links' capsule radius, one for every link or ``n + 1`` (the fixed
    base, then the link each moving joint moves).
    """
    try:
        import yourdfpy
    except ImportError as exc:  # pragma: no cover - depends on the installed extras
        raise InvalidInputError(
            "reading URDF needs the optional dependency yourdfpy: pip install 'armpath[urdf]'"
        ) from exc
    p = Path(path)
    _check_well_formed(p)
    try:
        urdf = yourdfpy.URDF.load(str(p), load_meshes=False, build_scene_graph=False)
    except KeyError as exc:  # an element without an attribute yourdfpy reads unguarded
        raise InvalidInputError(
            f"URDF {p.name!r} could not be parsed: an element lacks its {exc.args[0]!r} attribute"
        ) from None
    except Exception as exc:  # yourdfpy raises many types for malformed URDF
        raise InvalidInputError(f"URDF {p.name!r} could not be parsed: {exc}") from exc
    for element, named in (
        ("joint", [j.name for j in urdf.robot.joints]),
        ("link", [lk.name for lk in urdf.robot.links]),
    ):
        twice = sorted(n for n, count in Counter(named).items() if count > 1)
        if twice:  # yourdfpy keeps both: a chain by name would be ambiguous
            raise InvalidInputError(
                f"URDF {p.name!r}: more than one {element} is named {twice[0]!r}; each "
                f"{element} needs a name of its own"
            )
    link_names = {lk.name for lk in urdf.robot.links}
    for j in urdf.robot.joints:
        for role, name in (("parent", j.parent), ("child", j.child)):
            if name not in link_names:
                raise InvalidInputError(
                    f"URDF {p.name!r}: joint {j.name!r} names {role} link {name!r}, which is "
                    "not a link of the file"
                )
    joints_by_child = {j.child: j for j in urdf.robot.joints}
    roots = [lk.name for lk in urdf.robot.links if lk.name not in joints_by_child]
    if len(roots) != 1:
        raise InvalidInputError(f"URDF {p.name!r}: expected one root link, found {roots}")

    def depth(link: str) -> int:
        n = 0
        while link in joints_by_child:
            link = joints_by_child[link].parent
            n += 1
        return n

    if tip_link is None:
        tip_link = _default_tip([lk.name for lk in urdf.robot.links], joints_by_child, depth)
    elif tip_link not in {lk.name for lk in urdf.robot.links}:
        raise InvalidInputError(f"URDF {p.name!r}: no link named {tip_link!r}")
    path_joints = []
    link = tip_link
    while link in joints_by_child:
        path_joints.append(joints_by_child[link])
        link = joints_by_child[link].parent
    path_joints.reverse()

    joints: list[Joint] = []
    carry = np.eye(4)
    for uj in path_joints:
        origin = np.eye(4) if uj.origin is None else np.array(uj.origin, dtype=np.float64)
        for k, coordinate in enumerate("xyz"):
            where = f"URDF {p.name!r}: joint {uj.name!r} origin xyz ({coordinate})"
            check_length(float(origin[k, 3]), where, "m")
        origin[:3, 3] *= _M_TO_MM
        if uj.type == "fixed":
            carry = carry @ origin
            continue
        if _mimics(uj):
            raise InvalidInputError(
                f"URDF {p.name!r}: joint {uj.name!r} mimics joint {uj.mimic.joint!r}; armpath "
                "commands every joint on its own, so a mimic joint is not supported"
            )
        if uj.type is None:
            raise InvalidInputError(f"URDF {p.name!r}: joint {uj.name!r} has no type")
        if uj.type not in ("revolute", "continuous", "prismatic"):
            raise InvalidInputError(
                f"URDF {p.name!r}: joint {uj.name!r} of type {uj.type!r} is not supported "
                "(revolute, continuous, prismatic, fixed)"
            )
        kind = JointKind.PRISMATIC if uj.type == "prismatic" else JointKind.REVOLUTE
        scale = _M_TO_MM if kind is JointKind.PRISMATIC else 1.0
        lo, hi = -np.inf, np.inf
        if uj.type != "continuous":
            _check_limit_given(p, uj)  # both sides given
            lo, hi = float(uj.limit.lower) * scale, float(uj.limit.upper) * scale
        if lo > hi:
            unit = "m" if kind is JointKind.PRISMATIC else "rad"
            raise InvalidInputError(
                f"URDF {p.name!r}: joint {uj.name!r} limits: lower {lo / scale:g} {unit} is above "
                f"upper {hi / scale:g} {unit}"
            )
        if kind is JointKind.PRISMATIC:  # lengths, as the origins
            for side, v in (("lower", lo), ("upper", hi)):
                if np.isfinite(v):
                    check_length(v, f"URDF {p.name!r}: joint {uj.name!r} limit {side}")
        if kind is JointKind.REVOLUTE:
            check_turns(
                (lo, hi),
                f"URDF {p.name!r}: joint {uj.name!r} limits",
                hint="a URDF's limits are radians: were they written in degrees?",
            )
        axis = np.array([1.0, 0.0, 0.0]) if uj.axis is None else np.array(uj.axis, dtype=float)
        joints.append(Joint(uj.name, carry @ origin, axis, kind, (lo, hi)))
        carry = np.eye(4)
    if not joints:
        raise InvalidInputError(f"URDF {p.name!r}: the chain to {tip_link!r} has no moving joint")
    # the arm itself, from its first moving joint's origin on (fixed joints before it place
    # the robot in its world, which may lie far off)
    first = next(i for i, uj in enumerate(path_joints) if uj.type != "fixed")
    chain_mm = sum(
        float(np.linalg.norm(np.array(uj.origin, dtype=np.float64)[:3, 3])) * _M_TO_MM
        for uj in path_joints[first:]
        if uj.origin is not None
    )
    if chain_mm > MAX_CHAIN_M * _M_TO_MM:
        raise InvalidInputError(
            f"URDF {p.name!r}: its joint origins add up to {chain_mm / _M_TO_MM:,.0f} m, more "
            f"than the {MAX_CHAIN_M:g} m armpath takes for an arm; a URDF's lengths are metres: "
            "were they written in mm?"
        )
    n = len(joints)
    names = ("base", *(j.name for j in joints), "tool")
    radii = link_radii(link_radii_mm, n, f"URDF {p.name!r}: link radii")
    landmarks, links = physical_links(joints, carry, names, radii)
    robot = urdf.robot.name or p.stem
    return SerialArm(
        name=f"{robot} [{tip_link}]",
        joints=tuple(joints),
        T_flange_tool=carry,
        T_joint_flange=carry,
        landmarks=landmarks,
        links=links,
        home=default_home(joints),
        length_unit="mm",
    )
