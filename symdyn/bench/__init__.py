"""Checks against peers: the benchmark (generated code against Pinocchio, C++
and Python, and the Robotics Toolbox) with its C timing harness and the peer
models, and the differential checks of any arm, stage by stage."""
