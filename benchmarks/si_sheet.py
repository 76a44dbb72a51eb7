"""A sheet in SI units, three ways to its fold lengths: the same L0*, L1*, in metres too.

    python benchmarks/si_sheet.py [HMAX]

The sheet: base 4 cm, length 5.5 cm, tip 3.6 cm, thickness 1.2 mm, clamp radius 1.6 cm,
E 6.0e5 Pa, density 1150 kg/m^3 (L/a 1.375, b/a 0.9, a/R 2.5, E/(rho g a) 1329.6):
``fold_lengths(Sheet.from_si(...), hmax=HMAX)``, ``python -m skfem_sheet bistability --si
... --hmax HMAX --json``, and ``solve_both(sheet, hmax=HMAX, folds=True)`` (default HMAX
0.05).
"""
import json
import os
import subprocess
import sys
import tempfile
import time

from skfem_sheet import Sheet, fold_lengths, solve_both

SI = dict(base_width=0.04, length=0.055, tip_width=0.036, thickness=1.2e-3, radius=0.016,
          youngs_modulus=6.0e5, density=1150)
H = float(sys.argv[1]) if len(sys.argv) > 1 else 0.05
JSON = os.path.join(tempfile.mkdtemp(), "bistability.json")
sheet = Sheet.from_si(**SI)
print(repr(sheet))
t = time.perf_counter()
f = fold_lengths(sheet, hmax=H)
print(f"python fold_lengths ({time.perf_counter() - t:.0f} s):")
print(f)
arg = ",".join(f"{k}={v:g}" for k, v in SI.items())
t = time.perf_counter()
out = subprocess.run([sys.executable, "-m", "skfem_sheet", "bistability", "--si", arg, "--hmax", str(H),
                      "--json", JSON, "--quiet"], capture_output=True, text=True)
print(f"bistability --si ({time.perf_counter() - t:.0f} s), exit {out.returncode}:")
print(out.stdout)
cli = json.load(open(JSON))
t = time.perf_counter()
both = solve_both(sheet, hmax=H, folds=True)
print(f"solve_both(folds=True) ({time.perf_counter() - t:.0f} s):")
print(both)
rows = [("fold_lengths", f.popup_length, f.standout_length),
        ("bistability --si", cli["popup_length"], cli["standout_length"]),
        ("solve_both(folds=True)", both.folds.popup_length, both.folds.standout_length)]
print("\nL0*, L1* (L/a) and in mm:")
for name, a, b in rows:
    print(f"  {name:24s} {a:.7f} {b:.7f}   {40 * a:.4f} mm {40 * b:.4f} mm")
print("largest difference:", max(abs(r[1] - rows[0][1]) for r in rows), max(abs(r[2] - rows[0][2]) for r in rows))
print("CLI JSON si:", json.dumps(cli["si"]))
