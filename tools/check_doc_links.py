#!/usr/bin/env python3
# Dead-link check: every relative link in README.md and docs/*.md names an existing file, and
# every #anchor a heading of that file (GitHub's slugs).
import re, os, sys, glob
root = sys.argv[1] if len(sys.argv) > 1 else '.'
os.chdir(root)
def slugs(path):
    out, seen = set(), {}
    text = open(path).read()
    text = re.sub(r'```.*?```', '', text, flags=re.S)
    for m in re.finditer(r'^#{1,6} (.+)$', text, re.M):
        s = m.group(1).strip().lower()
        s = re.sub(r'[^\w\- ]', '', s).replace(' ', '-')
        n = seen.get(s, 0); seen[s] = n + 1
        out.add(s if n == 0 else f'{s}-{n}')
    out.add('top')
    return out
bad = 0; count = 0
for f in ['README.md'] + sorted(glob.glob('docs/*.md')):
    text = re.sub(r'```.*?```', '', open(f).read(), flags=re.S)
    for m in re.finditer(r'\]\(([^)\s]+)\)', text):
        t = m.group(1)
        if re.match(r'[a-z]+:', t): continue
        count += 1
        path, _, anchor = t.partition('#')
        target = os.path.normpath(os.path.join(os.path.dirname(f), path)) if path else f
        if not os.path.exists(target):
            print(f'{f}: dead link {t} (no {target})'); bad += 1; continue
        if anchor and target.endswith('.md') and anchor not in slugs(target):
            print(f'{f}: dead anchor {t}'); bad += 1
print(f'{count} links checked, {bad} dead')
sys.exit(1 if bad else 0)
