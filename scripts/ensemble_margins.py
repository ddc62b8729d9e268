# Each member of a stored ensemble sweep: the layout lowest in the outlet Q_m and its margin over the next
# (docs/study.md, "An ensemble on the flume"). Usage: ensemble_margins.py RUNOUT_DB SWEEP QUANTUM_M3_S
import sqlite3, sys, re, collections
db = sqlite3.connect(sys.argv[1])
q = collections.defaultdict(dict)
for v, val in db.execute("SELECT r.variant, m.value FROM runs r JOIN metrics m ON m.run_id = r.id WHERE r.status='completed' "
                          "AND r.sweep=? AND m.name='monitors.section.Outlet.peak_discharge_m3_s'", (sys.argv[2],)):
    lay, mem = re.match(r"(.+)-e(\d+)$", v).groups()
    q[int(mem)][lay] = val
quantum = float(sys.argv[3])
phi = {}
for v, mj in db.execute("SELECT variant, manifest_json FROM runs WHERE sweep=? AND variant LIKE 'C0-e%'", (sys.argv[2],)):
    import json
    phi[int(v.split('-e')[1])] = json.loads(mj)["scene"]["materials"][0]["friction_angle"]
unresolved = 0
for mem in sorted(q):
    s = sorted(q[mem].items(), key=lambda kv: kv[1])
    margin = s[1][1] - s[0][1]
    unresolved += margin < quantum
    print(f"e{mem:03d} phi {phi.get(mem, float('nan')):.2f}: first {s[0][0]} {s[0][1]:.5f}, next {s[1][0]} {s[1][1]:.5f}, margin {margin:.5f} m3/s"
          + ("  (< one quantum)" if margin < quantum else ""))
print(f"{unresolved} of {len(q)} members won by less than one quantum ({quantum} m3/s)")
