"""SRDF reading (MoveIt's semantic robot description): groups, group states, end effectors,
passive joints, virtual joints and disabled collision pairs."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from robocell.errors import ModelError


@dataclass
class GroupSpec:
    """A planning group as the SRDF writes it (resolved into joints by the model)."""

    name: str
    chains: list[tuple[str, str]] = field(default_factory=list)  # (base_link, tip_link)
    joints: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    subgroups: list[str] = field(default_factory=list)


@dataclass
class EndEffectorSpec:
    name: str
    parent_link: str
    group: str
    parent_group: str | None = None


@dataclass
class VirtualJointSpec:
    name: str
    type: str
    parent_frame: str
    child_link: str


@dataclass
class Srdf:
    name: str = ""
    groups: list[GroupSpec] = field(default_factory=list)
    group_states: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    end_effectors: list[EndEffectorSpec] = field(default_factory=list)
    passive_joints: list[str] = field(default_factory=list)
    virtual_joints: list[VirtualJointSpec] = field(default_factory=list)
    disabled_collisions: list[tuple[str, str, str]] = field(default_factory=list)
    enabled_collisions: list[tuple[str, str]] = field(default_factory=list)
    disabled_default: list[str] = field(default_factory=list)
    source: str = ""


def _need(el: ET.Element, attr: str, source: str) -> str:
    val = el.get(attr)
    if not val:
        raise ModelError(f"{source}: <{el.tag}> needs a {attr!r} attribute")
    return val


def parse_srdf(text: str, source: str = "<string>") -> Srdf:
    """Parse SRDF XML text (names are checked against the URDF by the model)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(f"{source}: not valid XML: {exc}") from exc
    if root.tag != "robot":
        raise ModelError(f"{source}: the root element is <{root.tag}>, expected <robot>")
    srdf = Srdf(name=root.get("name", ""), source=source)
    for g in root.findall("group"):
        spec = GroupSpec(_need(g, "name", source))
        for child in g:
            if child.tag == "chain":
                spec.chains.append(
                    (_need(child, "base_link", source), _need(child, "tip_link", source))
                )
            elif child.tag == "joint":
                spec.joints.append(_need(child, "name", source))
            elif child.tag == "link":
                spec.links.append(_need(child, "name", source))
            elif child.tag == "group":
                spec.subgroups.append(_need(child, "name", source))
        if any(s.name == spec.name for s in srdf.groups):
            raise ModelError(f"{source}: duplicate group {spec.name!r}")
        srdf.groups.append(spec)
    for s in root.findall("group_state"):
        group, name = _need(s, "group", source), _need(s, "name", source)
        values: dict[str, float] = {}
        for j in s.findall("joint"):
            raw = _need(j, "value", source).split()
            try:
                values[_need(j, "name", source)] = float(raw[0])
            except (ValueError, IndexError) as exc:
                raise ModelError(
                    f"{source}: group_state {name!r} joint {j.get('name')!r}: bad value {raw}"
                ) from exc
        srdf.group_states.setdefault(group, {})[name] = values
    for e in root.findall("end_effector"):
        srdf.end_effectors.append(
            EndEffectorSpec(
                _need(e, "name", source),
                _need(e, "parent_link", source),
                _need(e, "group", source),
                e.get("parent_group"),
            )
        )
    for p in root.findall("passive_joint"):
        srdf.passive_joints.append(_need(p, "name", source))
    for v in root.findall("virtual_joint"):
        srdf.virtual_joints.append(
            VirtualJointSpec(
                _need(v, "name", source),
                v.get("type", "fixed"),
                v.get("parent_frame", "world"),
                _need(v, "child_link", source),
            )
        )
    for d in root.findall("disable_collisions"):
        srdf.disabled_collisions.append(
            (_need(d, "link1", source), _need(d, "link2", source), d.get("reason", ""))
        )
    for d in root.findall("enable_collisions"):
        srdf.enabled_collisions.append((_need(d, "link1", source), _need(d, "link2", source)))
    for d in root.findall("disable_default_collisions"):
        srdf.disabled_default.append(_need(d, "link", source))
    return srdf


def load_srdf(path: str | Path) -> Srdf:
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"SRDF file not found: {str(p)!r}")
    return parse_srdf(p.read_text(), str(p))
