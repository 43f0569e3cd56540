"""An arm's URDF from the `example-robot-data` package (no network), placed in the scene.

`urdf_path` finds the package's file; `model_urdf_text` gives the URDF the stack's models are
built from: the arm's root placed in the scene frame `base` (a new root link named `base`, when
the description moves the arm) and the tool frame added (when the URDF has none), with or
without the `<visual>` and `<collision>` elements. `placed_urdf_file` writes that text next to
nothing else (a cache file) for tools that need a file: the recorder's Rerun URDF loader.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sysconfig
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from handover_model.robots.description import RobotDescription, RobotDescriptionError

#: The scene frame's link name (Baxter's own root link).
BASE_LINK = "base"


def _share_dirs() -> list[Path]:
    candidates = [Path(sysconfig.get_paths()[key]) / "cmeel.prefix" / "share" for key in ("purelib", "platlib")]
    return [c for c in dict.fromkeys(candidates) if c.is_dir()]


@functools.cache
def share_dir() -> Path:
    """The `cmeel.prefix/share` folder that holds example-robot-data.

    Raises:
        RobotDescriptionError: when the package is not installed in this environment.
    """
    for share in _share_dirs():
        if (share / "example-robot-data").is_dir():
            return share
    raise RobotDescriptionError(
        "example-robot-data is not installed in this Python environment "
        "(expected <site-packages>/cmeel.prefix/share/example-robot-data); install the project with `pip install -e .`")


def urdf_path(desc: RobotDescription) -> Path:
    """Absolute path of the arm's URDF, with ROS_PACKAGE_PATH set so that meshes resolve."""
    share = share_dir()
    path = share / "example-robot-data" / "robots" / desc.urdf
    if not path.is_file():
        raise RobotDescriptionError(f"robot {desc.name!r}: URDF not found at {path}; reinstall example-robot-data")
    ros_path = os.environ.get("ROS_PACKAGE_PATH", "")
    if str(share) not in ros_path.split(os.pathsep):
        os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(p for p in (str(share), ros_path) if p)
    return path


def _fixed_joint(name: str, parent: str, child: str, xyz, rpy) -> ET.Element:
    joint = ET.Element("joint", name=name, type="fixed")
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    ET.SubElement(joint, "origin", xyz=" ".join(f"{v:.9g}" for v in xyz), rpy=" ".join(f"{v:.9g}" for v in rpy))
    return joint


def _rename_link(root: ET.Element, old: str, new: str) -> None:
    for link in root.iter("link"):
        if link.get("name") == old:
            link.set("name", new)
    for joint in root.iter("joint"):
        for tag in ("parent", "child"):
            for element in joint.findall(tag):
                if element.get("link") == old:
                    element.set("link", new)


def _root_link(root: ET.Element) -> str:
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    roots = [link.get("name") for link in root.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise RobotDescriptionError(f"URDF has {len(roots)} root links {roots}; expected one")
    return str(roots[0])


@functools.cache
def model_urdf_text(desc: RobotDescription, geometry: bool = False) -> str:
    """The URDF the stack builds `desc`'s models from (see the module docstring).

    Args:
        geometry: keep the links' `<visual>` and `<collision>` elements (False: joints, frames,
            limits and inertias only: no mesh is read, which saves PlaCo ≈ 2 s and 245 MB).

    Raises:
        RobotDescriptionError: the URDF is missing or not valid XML, or the tool parent is not
            one of its links.
    """
    try:
        root = ET.parse(urdf_path(desc)).getroot()
    except (OSError, ET.ParseError) as exc:
        raise RobotDescriptionError(f"could not read {desc.name}'s URDF: {exc}") from exc
    if not geometry:
        for link in root.iter("link"):
            for tag in ("visual", "collision"):
                for element in link.findall(tag):
                    link.remove(element)
    links = {link.get("name") for link in root.iter("link")}
    if desc.tool_parent is not None:
        if desc.tool_parent not in links:
            raise RobotDescriptionError(
                f"robot {desc.name!r}: tool_parent {desc.tool_parent!r} is not a link of its URDF")
        root.append(ET.Element("link", name=desc.tool_frame))
        root.append(_fixed_joint(f"{desc.tool_frame}_joint", desc.tool_parent, desc.tool_frame,
                                 desc.tool_xyz_m, desc.tool_rpy_rad))
    if desc.placed:
        if BASE_LINK in links:
            _rename_link(root, BASE_LINK, f"{desc.name}_{BASE_LINK}")
        arm_root = _root_link(root)
        root.insert(0, ET.Element("link", name=BASE_LINK))
        root.append(_fixed_joint(f"{BASE_LINK}_to_{arm_root}", BASE_LINK, arm_root, desc.base_xyz_m, desc.base_rpy_rad))
    return ET.tostring(root, encoding="unicode")


@functools.cache
def placed_urdf_file(desc: RobotDescription) -> Path:
    """`model_urdf_text(desc, geometry=True)` as a file (the original itself when the arm is
    neither moved nor given a tool frame), for loaders that read files."""
    original = urdf_path(desc)
    if not desc.placed and desc.tool_parent is None:
        return original
    folder = Path(tempfile.gettempdir()) / f"handover-robots-{os.getuid()}"
    folder.mkdir(mode=0o700, exist_ok=True)
    text = model_urdf_text(desc, geometry=True)
    path = folder / f"{desc.name}-{hashlib.sha1(text.encode()).hexdigest()[:12]}.urdf"
    if not path.is_file() or path.read_text() != text:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return path
