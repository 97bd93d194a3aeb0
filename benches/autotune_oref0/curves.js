// Prints oref0's insulin curve values (lib/iob/total.js resolution + calculate.js).
var calc = require('oref0/lib/iob/calculate');
var total = require('oref0/lib/iob/total');
var cases = [
  ['bilinear', 3, undefined], ['bilinear', 4, undefined],
  ['rapid-acting', 5, undefined], ['rapid-acting', 6, 90], ['rapid-acting', 4, 150],
  ['ultra-rapid', 5, undefined], ['ultra-rapid', 7, 30],
];
var rows = [];
cases.forEach(function (c) {
  [0, 5, 30, 60, 75, 120, 180, 239, 300, 359, 420].forEach(function (t) {
    var profile = {dia: c[1], curve: c[0]};
    if (c[2] !== undefined) { profile.useCustomPeakTime = true; profile.insulinPeakTime = c[2]; }
    var now = new Date(1700000000000 + t * 60000);
    var r = total({treatments: [{insulin: 1, date: 1700000000000}], profile: profile, calculate: calc}, now);
    // total.js rounds; recompute unrounded with its resolution of dia/peak
    var dia = Math.max(c[1], 3); if (c[0] !== 'bilinear') dia = Math.max(dia, 5);
    var peak = c[0] === 'ultra-rapid' ? 55 : 75;
    var x = calc({insulin: 1, date: 1700000000000}, now, c[0], dia, peak, profile);
    rows.push([c[0], c[1], c[2], t, x.activityContrib || 0, x.iobContrib || 0, r.activity, r.iob]);
  });
});
console.log(JSON.stringify(rows));
