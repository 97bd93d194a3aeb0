// Prints the order node's Array.prototype.sort leaves arrays of numbers in
// under oref0's comparator (a, b) => a - b, when some are NaN (the
// comparator then answers NaN, taken as "equal"), as one FNV-1a hash of
// each case's permutation: crates/advisor/src/baselines/autotune/js_sort.rs's
// test draws the same arrays from the same generator and must leave them in
// the same order. Usage: node v8_sort_cases.js > ../../crates/advisor/tests/data/v8_sort_cases.json
'use strict';

// A 32-bit generator (xorshift32), the same in the Rust test.
function generator(seed) {
  let x = seed >>> 0 || 1;
  return function next() {
    x ^= x << 13; x >>>= 0;
    x ^= x >>> 17;
    x ^= x << 5; x >>>= 0;
    return x;
  };
}

// The value of element i of case `kind`: NaN, ±Infinity or a small number,
// in runs up and down for the merges' galloping.
function draw(next, kind, i) {
  const r = next();
  const nanEvery = [3, 10, 50, 1000000][kind % 4];
  if (r % nanEvery === 0) return NaN;
  if (r % 97 === 1) return (r & 2) ? Infinity : -Infinity;
  switch (Math.floor(kind / 4)) {
    case 0: return (r >>> 8) % 50;                   // many equal values
    case 1: return ((r >>> 8) % 100000) / 1000;      // few equal values
    case 2: return Math.floor(i / 40) % 2 ? 1000 - i + (r % 5) : i + (r % 5); // runs
    default: return (i % 300) - ((r >>> 8) % 3);     // long ascending runs
  }
}

function fnv(ids) {
  let h = 0x811c9dc5;
  for (const id of ids) {
    for (let k = 0; k < 4; k++) {
      h ^= (id >>> (8 * k)) & 0xff;
      h = Math.imul(h, 0x01000193) >>> 0;
    }
  }
  return h >>> 0;
}

const cases = [];
let seed = 1;
for (const len of [0, 1, 2, 5, 31, 32, 63, 64, 65, 100, 127, 128, 200, 253, 500, 1000, 2500]) {
  for (let kind = 0; kind < 16; kind++) {
    const next = generator(seed);
    const items = [];
    for (let i = 0; i < len; i++) items.push({ id: i, v: draw(next, kind, i) });
    items.sort(function (a, b) { return a.v - b.v; });
    cases.push({ seed, len, kind, hash: fnv(items.map((x) => x.id)) });
    seed++;
  }
}
process.stdout.write('{"generator": "benches/autotune_oref0/v8_sort_cases.js", "node": "' +
  process.version + '", "cases": [\n' + cases.map((c) => JSON.stringify(c)).join(',\n') + '\n]}\n');
