# Per variant: geometry-pass fragments per covered pixel (covered pixels from
# the overshading run's count histogram, same cameras) and bytes per frame.
import json, sys
r = json.load(open(sys.argv[1]))
covered = {}
for run in r['runs']:
    for i, s in enumerate(run['samples']):
        ex = s['extras'].get('overdraw')
        if ex and ex['mode'] == 'overshading':
            covered[(run['scene'], i)] = ex['covered_pixels']
for run in r['runs']:
    geo = 'gbuffer' if run['renderer'] == 'deferred' else 'forward'
    frag = cov = tot = 0
    agrees = []
    for i, s in enumerate(run['samples']):
        for p in s['passes']:
            tot += sum(a['bytes'] for a in p['resources'])
            if p['name'] == geo: frag += p['fragment_invocations']
        cov += covered[(run['scene'], i)]
        ex = s['extras'].get('overdraw')
        if ex: agrees.append(ex['agrees'] and ex['fragments'] == ex['counted_fragments'])
    n = len(run['samples'])
    print(f"| {run['scene']} | {run['variant']} | {frag / cov:.3f} | {tot / n / 1e6:.2f} | "
          f"{('%d/%d' % (sum(agrees), len(agrees))) if agrees else '-'} |")
