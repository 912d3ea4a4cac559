"""Write a mesh-free copy of a URDF: kinematics, inertias, limits and dynamics only.

    python scripts/strip_urdf.py IN.urdf OUT.urdf --source "where it came from" [--drop LINK ...]

Removes <visual>, <collision>, <material>, <gazebo>, <transmission> and other
simulator elements; `--drop` removes links (and the joints that reach them),
e.g. the Panda's fingers.  How the shipped URDFs in symdyn/model/arms/data/
were made (see each file's header comment).
"""

import argparse
import xml.etree.ElementTree as ET

KEEP_LINK = {"inertial"}
KEEP_JOINT = {"origin", "parent", "child", "axis", "limit", "dynamics", "mimic"}


def strip(text: str, drop: set[str]) -> ET.Element:
    robot = ET.fromstring(text)
    for element in list(robot):
        tag = element.tag
        name = element.get("name")
        if tag == "link" and name not in drop:
            for child in list(element):
                if child.tag not in KEEP_LINK:
                    element.remove(child)
        elif tag == "joint" and element.find("child").get("link") not in drop:
            for child in list(element):
                if child.tag not in KEEP_JOINT:
                    element.remove(child)
                elif child.tag in ("limit", "dynamics"):  # drop simulator-specific attributes
                    for key in list(child.attrib):
                        if key not in ("lower", "upper", "effort", "velocity", "damping", "friction"):
                            del child.attrib[key]
        else:
            robot.remove(element)
    return robot


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source_file", help="the URDF to strip")
    parser.add_argument("out", help="where to write the mesh-free URDF")
    parser.add_argument("--source", required=True, help="provenance, written into the header comment")
    parser.add_argument("--drop", nargs="*", default=[], help="links to leave out (with their joints)")
    args = parser.parse_args()
    with open(args.source_file) as f:
        robot = strip(f.read(), set(args.drop))
    ET.indent(robot, "  ")
    body = ET.tostring(robot, encoding="unicode")
    header = f'<?xml version="1.0"?>\n<!-- Mesh-free: {args.source} -->\n'
    with open(args.out, "w") as f:
        f.write(header + body + "\n")


if __name__ == "__main__":
    main()
