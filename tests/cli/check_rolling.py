#!/usr/bin/env python3
"""check_rolling.py OUTDIR: examples/rolling_plane.toml run by the executable. The sphere,
launched sliding at 1 m/s (mu_s = 0.5, mu_r = 0.1), stops at t = 1.0194 s after landing (closed
form, docs/scene.md "Walls"): kinetic energy still above 1e-7 J at the last row before 0.99 s,
below 1e-9 J from 1.03 s on; the energy account closes to 1e-5 (books = input)."""
import csv, sys

rows = list(csv.DictReader(open(sys.argv[1] + '/series.csv')))
moving = [float(r['kinetic']) for r in rows if float(r['time']) < 0.99]
stopped = [float(r['kinetic']) for r in rows if float(r['time']) >= 1.03]
last = rows[-1]
books = sum(float(last[k]) for k in ('kinetic', 'e_normal', 'e_shear', 'e_rolling', 'diss_friction',
                                      'diss_rolling', 'diss_viscous', 'diss_local'))
inp = float(last['energy_input'])
print(f"kinetic before 0.99 s {moving[-1]:.3e} J, after 1.03 s at most {max(stopped):.3e} J; "
      f"books {books:.9e} J, input {inp:.9e} J")
sys.exit(0 if moving[-1] > 1e-7 and max(stopped) < 1e-9 and abs(books / inp - 1) < 1e-5 else 1)
