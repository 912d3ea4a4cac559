"""The numeric stage: the recursive reference (NumPy, never sympy), the same
recursion on CasADi symbols, and the back-end that evaluates a model fast."""
