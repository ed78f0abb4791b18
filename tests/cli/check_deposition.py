#!/usr/bin/env python3
"""check_deposition.py DATA OUTDIR [TOL [LID_PRESSURE]]: a deposition on a floor
(examples/deposition.toml) at rest carries its weight. The last row of OUTDIR/series.csv: the
floor's force wall1_fz equals -sum m g of the spheres in the LAMMPS data file DATA (relative TOL,
default 1e-3), so that the pressure on the floor is the weight over the cell's cross-section;
with LID_PRESSURE (Pa; examples/servo_wall.toml, whose wall 2 is a servo lid), the lid's force
wall2_fz equals LID_PRESSURE x the cross-section and the floor carries it as well as the weight
(both to TOL), and the lid has come down from its start (wall2_position below the scene's z); the energy account closes
(|books - input| / input < 2e-2, books = kinetic + elastic + dissipated: the account of the
dashpots' impacts is first order in dt, 0.9 % at time_step_fraction 0.25 here, 2.8 / 1.0 / 0.5 %
at 0.25 / 0.1 / 0.05 with local damping 0.3); the wall contacts are counted apart
(wall_contacts, at least one sphere on the floor); with h5py, the wall contacts and the walls'
positions of the last snapshot of run.h5 and its contacts' XDMF sidecar (below)."""
import csv, math, sys

data, out = sys.argv[1], sys.argv[2]
tol = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-3
lid_pressure = float(sys.argv[4]) if len(sys.argv) > 4 else None
g = 9.81
weight, section, box = 0.0, None, {}
for line in open(data):
    w = line.split('#')[0].split()
    if not w:
        continue
    if len(w) == 4 and w[2].endswith('lo'):
        box[w[2][0]] = float(w[1]) - float(w[0])
    if w[0] in ('Atoms', 'Velocities'):
        section = w[0]
        continue
    if section == 'Atoms' and len(w) >= 7:
        d, rho = float(w[2]), float(w[3])
        weight += rho * math.pi / 6 * d ** 3 * g
rows = list(csv.DictReader(open(out + '/series.csv')))
last = rows[-1]
fz = float(last['wall1_fz'])
area = box['x'] * box['y']
books = sum(float(last[k]) for k in ('kinetic', 'e_normal', 'e_shear', 'e_rolling', 'diss_friction',
                                      'diss_rolling', 'diss_viscous', 'diss_local'))
inp = float(last['energy_input'])
print(f"floor force {fz:.6e} N, weight {weight:.6e} N (with a lid: below); pressure "
      f"{-fz / area:.4f} Pa = weight / area {weight / area:.4f} Pa; kinetic {float(last['kinetic']):.3e} J; "
      f"wall contacts {last['wall_contacts']}, particle contacts {last['contacts']}; energy books "
      f"{books:.6e} J, input {inp:.6e} J")
floor_load = weight
if lid_pressure is not None:
    lid, target = float(last['wall2_fz']), lid_pressure * area
    floor_load = weight + target
    first = float(rows[0]['wall2_position'])
    print(f"servo lid: force {lid:.6e} N, target {target:.6e} N, rel err {lid / target - 1:.2e}; floor "
          f"carries {-fz:.6e} N = lid + weight {floor_load:.6e} N, rel err {-fz / floor_load - 1:.2e}; "
          f"lid at {float(last['wall2_position']):.6e} m (first row {first:.6e} m)")
    ok = abs(lid / target - 1) < tol and float(last['wall2_position']) < first
else:
    ok = True
ok = ok and abs(-fz / floor_load - 1) < tol and abs(books / inp - 1) < 2e-2 and int(last['wall_contacts']) >= 1

# The last snapshot of OUT/run.h5 (with h5py): its contact rows hold the wall contacts (id2 =
# -1 - wall index, docs/output.md), as many as the series' wall_contacts and the group's
# attribute say, the elastic normal forces of the floor's summing to its force (at rest: 1e-9), none
# strong; the contacts' XDMF sidecar describes every row (particle and wall contacts).
try:
    import h5py
except ImportError:
    print("run.h5 not checked: /usr/bin/python3 has no h5py")
    sys.exit(0 if ok else 1)
import re
with h5py.File(out + '/run.h5', 'r') as f:
    g = f['snapshots/run']
    snap = g[sorted(g.keys())[-1]]
    c = snap['contacts']
    wall = c['id2'][:] < 0
    floor = c['id2'][:] == -1  # wall index 0
    fn_walls = c['fn'][:][floor].sum()
    rows = int(snap.attrs['contacts'])
    print(f"run.h5 {snap.name}: {rows} contact rows, {wall.sum()} with the wall (attribute "
          f"{int(snap.attrs['wall_contacts'])}), the floor's f_n sum {fn_walls:.9e} N; strong wall rows "
          f"{int(c['strong'][:][wall].sum())}; wall ids {sorted(set((-1 - c['id2'][:][wall]).tolist()))}")
    ok = ok and wall.sum() == int(snap.attrs['wall_contacts']) == int(last['wall_contacts'])
    # With the servo lid the layer keeps a residual motion (kinetic energy ~1e-6 of the input: the
    # servo answers each vibration), so the dashpots' share of the series' force: 1e-6 there.
    rest = 1e-9 if lid_pressure is None else 1e-6
    ok = ok and abs(fn_walls / -fz - 1) < rest and c['strong'][:][wall].sum() == 0
    walls_touched = [0] if lid_pressure is None else [0, 1]
    ok = ok and sorted(set((-1 - c['id2'][:][wall]).tolist())) == walls_touched and rows == len(c['id2'])
    # Where the walls are at the snapshot's step (attributes wall_points, wall_normals): each
    # wall's point . |normal| equals the series' wallk_position of the row at that step (to the
    # CSV's 10 digits), and the normals are the scene's unit normals (+z floor, -z lid).
    points = snap.attrs['wall_points'].reshape(-1, 3)
    normals = snap.attrs['wall_normals'].reshape(-1, 3)
    step = int(snap.attrs['step'])
    at = [r for r in csv.DictReader(open(out + '/series.csv')) if int(r['step']) == step]
    n_walls = 1 if lid_pressure is None else 2
    want_normals = [[0, 0, 1], [0, 0, -1]][:n_walls]
    print(f"run.h5 {snap.name}: wall points {points.tolist()}, normals {normals.tolist()}; series row at "
          f"step {step}: {[at[0][f'wall{k + 1}_position'] for k in range(n_walls)] if at else 'none'}")
    ok = ok and len(at) == 1 and points.shape == (n_walls, 3) and normals.tolist() == want_normals
    ok = ok and all(abs(points[k] @ abs(normals[k]) - float(at[0][f'wall{k + 1}_position']))
                    <= 1e-9 * max(1.0, abs(points[k] @ abs(normals[k]))) for k in range(n_walls))
xmf = open(out + '/run_contacts.xmf').read()
m = re.findall(r'NumberOfElements="(\d+)"', xmf)
print(f"run_contacts.xmf: line cells per snapshot {m[-1:]}")
ok = ok and m and int(m[-1]) == rows
sys.exit(0 if ok else 1)
