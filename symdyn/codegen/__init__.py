"""The codegen stage: function specs from the derivations, emitters (NumPy, C +
binding, CasADi) that print their straight-line programs, `generate()`/`load()`."""
