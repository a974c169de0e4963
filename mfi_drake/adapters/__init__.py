"""MFI inside other simulators: `adapters.rotorpy.RotorpyController`
(`pip install 'mfi_drake[rotorpy]'`, docs/vehicles.md, "MFI inside
rotorpy"). Each adapter imports its simulator only when used."""
