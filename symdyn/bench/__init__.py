"""The benchmark: generated code against Pinocchio (C++ and Python) and the
Robotics Toolbox, with its C timing harness and the peer models."""
