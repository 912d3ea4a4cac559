"""The presentation stage: closed forms for people — named elements (M11, C23,
G1, …) printed as text, pretty or LaTeX (`printing`), and the named-constant
form of Armstrong, Khatib & Burdick with its constants' definitions, values and
units (`constants`); a robot as read, drawn (`picture`).  A consumer of derivations beside codegen, as an emitter
is: it takes a `Dynamics` and the simplifier's forms from the derivation stage
and prints them; nothing in derivation or codegen imports it."""
