#!/usr/bin/python3
# The cost model's refit with the implicit viscous step (docs/tradeoff.md, "Refit with the implicit viscous step"):
# runout calibrate's least squares on relative time error (scenarios/src/cost_model.cpp, fit_cost_model), with the
# implicit step's extra passes p_D re-derived from the side-by-side step times below at each fitted a_D, until a_D
# and p_D agree. Prints p_D, the coefficients and each run's error.
#   /usr/bin/python3 scripts/cost_fixed_point.py flume.db catch.db val.db     (Debian's python3-numpy)
import json, sqlite3, math, sys
import numpy as np
runs=[]
for db in sys.argv[1:]:
    for (mj,) in sqlite3.connect(db).execute("select metrics_json from runs where status='completed'"):
        m=json.loads(mj); c=m['cost_features']
        impl = (m.get('settings',{}).get('viscosity')=='implicit')
        runs.append(dict(D=m['dimensions'], F=c['fluid_mean']*c['neighbours'], base=2.0 if c['passes']>1 else 1.0, impl=impl,
                         walls=m['particles'].get('boundary_peak',0), steps=m['steps'], wall=m['wall_time_s'], thr=m['threads'],
                         fluid_mean=c['fluid_mean'], label=m.get('scene'), dt0=c['dt0_s'], dur=c['duration_s']))
# Side-by-side step times, one thread, 2026-12-05 evening (docs/performance.md, "Implicit viscous step"):
# (D, fluid_mean (h/dp)^D, seconds a step implicit, explicit): the Bui column, the flume's C6 and the catchment's G7 at draft.
pairs=[(2,800*2.25,1.508e-3,0.568e-3),(3,300*3.375,1.270e-3,0.919e-3),(3,375*3.375,1.610e-3,1.269e-3)]
def speedup(n,threads,e=0.8,nh=70): return 1+e*n/(n+nh)*(threads-1)
def fit(D,p):
    obs=[r for r in runs if r['D']==D]
    cols=[0,1,2]
    while True:
        A=[];b=[]
        for r in obs:
            y=r['wall']*speedup(r['fluid_mean'],r['thr'])/r['steps']
            x=[r['F']*(r['base']+(p if r['impl'] else 0)), r['walls'], 1.0]
            A.append([x[c]/y for c in cols]); b.append(1.0)
        coef,*_=np.linalg.lstsq(np.array(A),np.array(b),rcond=None)
        neg=[i for i,v in enumerate(coef) if v<0]
        if neg and len(cols)>1:
            worst=min(neg,key=lambda i:coef[i]); cols.pop(worst); continue
        out=[0,0,0]
        for i,cc in enumerate(cols): out[cc]=max(0,coef[i])
        return out,obs
p={2:1.56,3:0.59}
for it in range(300):
    coefs={}
    for D in (2,3):
        coefs[D],_=fit(D,p[D])
    newp={}
    for D in (2,3):
        a=coefs[D][0]; vals=[(si-se)/(a*F) for (d,F,si,se) in pairs if d==D]
        newp[D]=math.exp(sum(math.log(v) for v in vals)/len(vals))
    if all(abs(newp[D]-p[D])<1e-4 for D in (2,3)): break
    p=newp
print('iterations',it,'p',p)
for D in (2,3):
    (a,b,c),obs=fit(D,p[D])
    print(f'D={D} a={a:.4g} b={b:.4g} c={c:.4g}')
    for r in obs:
        pred=(a*r['F']*(r['base']+(p[D] if r['impl'] else 0))+b*r['walls']+c)*r['steps']/speedup(r['fluid_mean'],r['thr'])
        print(f"  {r['label'][:28]:28s} impl={int(r['impl'])} steps={r['steps']} meas={r['wall']:.1f} pred={pred:.1f} err={100*(pred/r['wall']-1):+.1f}%")
print('with predicted steps (k_D duration / dt0):')
k={2:1.016,3:0.974}
for D in (2,3):
    (a,b,c),obs=fit(D,p[D])
    for r in obs:
        steps=math.ceil(k[D]*r['dur']/r['dt0'])
        sec=(a*r['F']*(r['base']+(p[D] if r['impl'] else 0))+b*r['walls']+c)*steps/speedup(r['fluid_mean'],r['thr'])
        print(f"| {r['label']} | {D} | {'implicit' if r['impl'] else 'explicit'} | {r['fluid_mean']:.0f} | {r['walls']} | {r['steps']} | {steps} | {r['wall']:.1f} | {sec:.1f} | {100*(sec/r['wall']-1):+.1f} % |")
