#!/usr/bin/env python3
"""Check the markdown links of README.md and docs/*.md in a checkout.

- every relative link [text](path) and [text](path#anchor) points to a file that exists, and the
  anchor to a heading of that file (GitHub's slug rule);
- every `bench/…` file link (a run's JSON, script, …) exists;
- (with --bench) every JSON file in docs/bench is linked from docs/benchmarks.md or another doc,
  and at most --max-json of them are kept.
Exit status 1 on any problem.  Usage: check_links.py [ROOT] [--bench] [--max-json N]
"""
import os, re, sys, unicodedata, glob

args = [a for a in sys.argv[1:]]
root = '.'
check_bench = '--bench' in args
max_json = 60
if '--max-json' in args:
    max_json = int(args[args.index('--max-json') + 1])
pos = [a for i, a in enumerate(args) if not a.startswith('--') and (i == 0 or args[i - 1] != '--max-json')]
if pos:
    root = pos[0]

def slug(heading):
    h = heading.strip().lower()
    h = re.sub(r'`', '', h)
    # drop inline links' targets: [text](url) -> text
    h = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', h)
    out = []
    for c in h:
        cat = unicodedata.category(c)
        if c in ' -_' or cat[0] in 'LMN':
            out.append(c)
    return ''.join(out).replace(' ', '-')

def anchors(path):
    seen = {}
    result = set()
    in_code = False
    for line in open(path, encoding='utf-8'):
        if line.startswith('```'):
            in_code = not in_code
            continue
        if in_code:
            continue
        m = re.match(r'^(#{1,6})\s+(.*?)\s*#*\s*$', line)
        if m:
            s = slug(m.group(2))
            n = seen.get(s, 0)
            result.add(s if n == 0 else f'{s}-{n}')
            seen[s] = n + 1
    return result

LINK = re.compile(r'(?<!!)\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+"[^"]*")?\)|!\[[^\]]*\]\(([^)\s]+)\)')
files = [os.path.join(root, 'README.md')] + sorted(glob.glob(os.path.join(root, 'docs', '*.md')))
problems = []
linked = set()
cache = {}
for f in files:
    in_code = False
    for n, line in enumerate(open(f, encoding='utf-8'), 1):
        if line.startswith('```'):
            in_code = not in_code
            continue
        if in_code:
            continue
        for m in LINK.finditer(line):
            target = m.group(1) or m.group(2)
            if re.match(r'^[a-z]+:', target):
                continue  # http:, https:, mailto:
            path, _, anchor = target.partition('#')
            dest = os.path.normpath(os.path.join(os.path.dirname(f), path)) if path else f
            if not os.path.exists(dest):
                problems.append(f'{f}:{n}: {target}: no such file')
                continue
            linked.add(os.path.abspath(dest))
            if anchor:
                if not dest.endswith('.md'):
                    problems.append(f'{f}:{n}: {target}: anchor into a non-markdown file')
                    continue
                if dest not in cache:
                    cache[dest] = anchors(dest)
                if anchor not in cache[dest]:
                    problems.append(f'{f}:{n}: {target}: no heading #{anchor} in {dest}')

if check_bench:
    bench = os.path.join(root, 'docs', 'bench')
    kept = sorted(glob.glob(os.path.join(bench, '*.json')))
    for j in kept:
        if os.path.abspath(j) not in linked:
            problems.append(f'{j}: kept but not linked from any doc')
    others = sorted(set(glob.glob(os.path.join(bench, '*'))) - set(kept))
    for o in others:
        if os.path.abspath(o) not in linked:
            problems.append(f'{o}: kept but not linked from any doc')
    if len(kept) > max_json:
        problems.append(f'{len(kept)} JSON files in docs/bench, more than {max_json}')
    print(f'{len(kept)} JSON files in docs/bench, {len(others)} other files')

for p in problems:
    print(p)
print(f'{len(files)} files checked, {len(problems)} problems')
sys.exit(1 if problems else 0)
