"""The derive stage: symbolic M, C, G, F and τ by Lagrange and by Newton–Euler,
the regressor, `derive()` and its cache; simplification, and the straight-line
program whose op counts both this stage and code generation report (printing
for readers is the presentation stage's, `symdyn.presentation`)."""
