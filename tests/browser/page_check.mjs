// The commissioning page in a real browser: Debian's chromium (/usr/bin/chromium, headless)
// driven by playwright-core. Run by tests/integration/web_page_browser_test.cpp against a
// running simulated cell; prints "READY" once the page is up (the test then triggers PLC
// cycles), then one JSON line with what it measured, and exits 0 when every check passed.
//
//   node page_check.mjs --url http://127.0.0.1:PORT/ --journal FILE --cycles N
//                       [--allowed 127.0.0.2] [--shots DIR] [--timeout-ms 20000] [--depth 1]
//
// Checks:
//  1. the page loads: status, jobs and the live WebSocket come up;
//  2. each of the next N OK cycles (read from the journal file, independent of the page) is
//     on the canvas within 1 s of the cycle (its result: the journal's time + total_ms; the
//     time from the trigger is reported too): the canvas says it drew that cycle and, on the
//     canvas's own pixels, the grasp point's magenta disc (vision/overlay.hpp) is at the
//     journal's u_px/v_px (times the page's scale), and not at a point away from the part;
//     with --depth (a 3D cell): the canvas shows the depth picture, i.e. it states its z
//     range (data-depth-mm, the legend under it) and its colour bar at the right edge runs
//     from red (near, top) to blue (far, bottom) on the canvas's pixels;
//  3. the cycles table equals the journal, field by field, for every row it shows;
//  4. the page's "Trigger a cycle" from this browser (127.0.0.1, not in web.allowed_clients)
//     is refused with 403 and no operator cycle runs; the same POST from --allowed (a second
//     loopback address as source) is accepted and its cycle reaches the journal.
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
const url = args.url;
const journalPath = args.journal;
const want = Number(args.cycles || 5);
const timeoutMs = Number(args['timeout-ms'] || 20000);
const failures = [];
const out = { latencies_ms: [], latencies_after_result_ms: [], rows_checked: 0 };
const fail = (what) => { failures.push(what); };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function journal() {
  if (!fs.existsSync(journalPath)) return [];
  return fs.readFileSync(journalPath, 'utf8').split('\n').filter((l) => l.trim()).map((l) => { try { return JSON.parse(l); } catch { return null; } }).filter(Boolean);
}

function post(pathAndQuery, localAddress, headers) {
  const u = new URL(pathAndQuery, url);
  return new Promise((resolve) => {
    const req = http.request({ host: u.hostname, port: u.port, path: u.pathname + u.search, method: 'POST', localAddress, headers },
      (res) => { let body = ''; res.on('data', (c) => body += c); res.on('end', () => resolve({ status: res.statusCode, body })); });
    req.on('error', (e) => resolve({ status: 0, body: String(e) }));
    req.end();
  });
}

const browser = await chromium.launch({
  executablePath: '/usr/bin/chromium',
  headless: true,
  // Debian's chromium as root, headless, with nothing reaching out to the network
  // (/work/.library/env/machines/cpp.md "Known to work").
  args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
         '--disable-component-update', '--disable-sync'],
});
let exitCode = 1;
try {
  const page = await browser.newPage({ viewport: { width: 1500, height: 1100 } });
  const consoleErrors = [];
  page.on('pageerror', (e) => consoleErrors.push(String(e)));

  // 1. the page loads
  const res = await page.goto(url, { waitUntil: 'load', timeout: timeoutMs });
  if (!res || res.status() !== 200) fail(`GET / answered ${res && res.status()}`);
  await page.waitForFunction(() => document.getElementById('wsstate').textContent === 'live' &&
    document.getElementById('cell').textContent.startsWith('vgrd · ') && document.querySelectorAll('#jobs tbody tr').length > 0,
  null, { timeout: timeoutMs }).catch(() => fail('the page did not come up (status, jobs, WebSocket)'));
  out.title = await page.title();
  console.log('READY');

  // 2. new cycles on the canvas within 1 s, checked on its pixels
  const before = journal();
  let last = before.length ? before[before.length - 1].cycle : 0;
  const seen = [];
  const deadline = Date.now() + timeoutMs + want * 3000;
  while (seen.length < want && Date.now() < deadline) {
    const fresh = journal().filter((j) => j.cycle > last);
    if (!fresh.length) { await sleep(10); continue; }
    const j = fresh[fresh.length - 1];  // the newest: the one the canvas must get to
    last = j.cycle;
    if (j.status !== 0 || !j.parts.length) continue;
    const p = j.parts[0];
    let state = null;
    const until = Date.now() + 3000;
    while (Date.now() < until) {
      state = await page.evaluate(([cycle, u, v]) => {
        const c = document.getElementById('live');
        if (Number(c.dataset.cycle) < cycle) return { drawn: Number(c.dataset.cycle) };
        const s = Number(c.dataset.scale) || 1;
        const ctx = c.getContext('2d');
        const at = (x, y) => ctx.getImageData(Math.round(x), Math.round(y), 1, 1).data;
        const magenta = (d) => d[0] > 180 && d[1] < 90 && d[2] > 180;
        const x = (u + 0.5) * s - 0.5, y = (v + 0.5) * s - 0.5;
        let hit = 0;
        for (let dy = -2; dy <= 2; ++dy) for (let dx = -2; dx <= 2; ++dx) hit += magenta(at(x + dx, y + dy)) ? 1 : 0;
        // A point well away from the part (60 px image px, inside the canvas): no disc there.
        const ax = x + (x > c.width / 2 ? -60 : 60) * s, ay = y + (y > c.height / 2 ? -60 : 60) * s;
        // The depth picture's colour bar (vision/overlay.hpp): at the right edge, half the
        // height, centred; 1 px inside its ends.
        const barW = Math.max(10, Math.floor(c.width / 48)), barH = Math.max(32, Math.floor(c.height / 2));
        const barX = c.width - 4 - barW + Math.floor(barW / 2), top = Math.floor((c.height - barH) / 2);
        return { drawn: Number(c.dataset.cycle), hit, away: magenta(at(ax, ay)), w: c.width, h: c.height,
                 depthMm: c.dataset.depthMm, legend: document.getElementById('live-legend').textContent,
                 barTop: Array.from(at(barX, top + 1)), barBottom: Array.from(at(barX, top + barH - 2)) };
      }, [j.cycle, p.u_px, p.v_px]);
      if (state.drawn > j.cycle) break;          // already past it: a newer cycle is up (too fast to see)
      if (state.drawn === j.cycle && state.hit >= 9) break;
      await sleep(10);
    }
    const now = Date.now();
    if (state.drawn === j.cycle && state.hit >= 9) {
      out.latencies_ms.push(now - Math.round(j.time * 1000));
      out.latencies_after_result_ms.push(now - Math.round(j.time * 1000 + j.total_ms));
      if (state.away) fail(`cycle ${j.cycle}: magenta away from the part too (the canvas is not showing a grasp point)`);
      if (!args.depth && state.depthMm) fail(`cycle ${j.cycle}: a 2D picture states a depth range (${state.depthMm})`);
      if (args.depth) {
        const [r0, g0, b0] = state.barTop, [r1, g1, b1] = state.barBottom;
        if (!/^[0-9.]+,[0-9.]+$/.test(state.depthMm || '')) fail(`cycle ${j.cycle}: the canvas states no depth range (data-depth-mm '${state.depthMm}')`);
        if (!state.legend.startsWith('depth frame: ')) fail(`cycle ${j.cycle}: no depth legend under the picture ('${state.legend}')`);
        if (!(r0 > 80 && r0 > g0 + 50 && r0 > b0 + 50)) fail(`cycle ${j.cycle}: the colour bar's top is not red (near): rgb ${state.barTop}`);
        if (!(b1 > g1 + 20 && b1 >= r1)) fail(`cycle ${j.cycle}: the colour bar's bottom is not blue (far): rgb ${state.barBottom}`);
        out.depth_mm = state.depthMm;
      }
      seen.push(j.cycle);
      if (args.shots && seen.length === 1) {  // the live image of an OK cycle, for docs/
        fs.mkdirSync(args.shots, { recursive: true });
        await (await page.$('#live')).screenshot({ path: path.join(args.shots, args.depth ? 'commissioning-live-3d.png' : 'commissioning-live.png') });
      }
    } else if (state.drawn > j.cycle) {
      continue;  // not counted: the next one is checked
    } else {
      fail(`cycle ${j.cycle}: not on the canvas within 3 s (canvas shows cycle ${state && state.drawn}, ${state && state.hit} magenta px at the grasp point)`);
      break;
    }
  }
  out.cycles_checked = seen;
  if (seen.length < want) fail(`only ${seen.length} of ${want} cycles checked on the canvas`);
  // "Within 1 s of the cycle": from the cycle's end (its result: trigger time + total_ms).
  for (const [i, l] of out.latencies_after_result_ms.entries())
    if (l > 1000) fail(`cycle ${seen[i]}: its overlay was on the canvas ${l} ms after the cycle's result (bound 1000 ms)`);

  // 3. the table equals the journal
  await sleep(300);
  const rows = await page.$$eval('#cycles tbody tr', (trs) => trs.map((tr) => {
    const r = {};
    for (const td of tr.querySelectorAll('td[data-field]')) r[td.dataset.field] = td.textContent;
    r.cycle = Number(tr.dataset.cycle);
    return r;
  }));
  const byCycle = new Map(journal().map((j) => [j.cycle, j]));
  for (const r of rows) {
    const j = byCycle.get(r.cycle);
    if (!j) { fail(`table row cycle ${r.cycle}: not in the journal`); continue; }
    const p = j.parts[0] || {};
    const eq = (field, shown, value) => {
      const same = value === undefined ? shown === '' : (typeof value === 'number' ? Number(shown) === value : shown === String(value));
      if (!same) fail(`cycle ${r.cycle} ${field}: page shows '${shown}', the journal has ${JSON.stringify(value)}`);
    };
    eq('job', r.job, j.job);
    eq('trigger', r.trigger, j.trigger);
    eq('status', r.status, `${j.status} ${j.status_name}`);
    eq('parts', r.parts, j.parts.length);
    for (const f of ['x_mm', 'y_mm', 'z_mm', 'rz_deg', 'score']) eq(f, r[f], p[f]);
    for (const f of ['grab_ms', 'locate_ms', 'total_ms']) eq(f, r[f], j[f]);
    eq('archive', r.archive, j.archive === undefined ? '' : j.archive);
    ++out.rows_checked;
  }
  if (out.rows_checked < want) fail(`only ${out.rows_checked} table rows compared with the journal`);

  // 4. operator actions: refused from this browser's address, accepted from --allowed
  const operatorBefore = journal().filter((j) => j.trigger === 'operator').length;
  const [resp] = await Promise.all([
    page.waitForResponse((r) => r.url().includes('/api/trigger'), { timeout: timeoutMs }),
    page.click('#trigger'),
  ]);
  out.refused_status = resp.status();
  if (resp.status() !== 403) fail(`the page's trigger from 127.0.0.1 answered ${resp.status()}, expected 403`);
  await page.waitForFunction(() => (document.getElementById('action-result').textContent || '').startsWith('refused: 403'), null, { timeout: 5000 })
    .catch(() => fail('the page does not say the action was refused'));
  out.refused_text = await page.textContent('#action-result');
  if (args.allowed) {
    const noHeader = await post('/api/trigger', args.allowed, {});
    out.allowed_without_header_status = noHeader.status;
    if (noHeader.status !== 403) fail(`POST from ${args.allowed} without X-Vgr-Action answered ${noHeader.status}, expected 403`);
    const ok = await post('/api/trigger', args.allowed, { 'X-Vgr-Action': '1' });
    out.allowed_status = ok.status;
    if (ok.status !== 200) fail(`POST from ${args.allowed} answered ${ok.status} ${ok.body}, expected 200`);
    else {
      const cycle = JSON.parse(ok.body).cycle;
      out.allowed_cycle = cycle;
      const until = Date.now() + 5000;
      while (Date.now() < until && !journal().some((j) => j.cycle === cycle && j.trigger === 'operator')) await sleep(20);
      if (!journal().some((j) => j.cycle === cycle && j.trigger === 'operator')) fail(`the allowed trigger's cycle ${cycle} is not in the journal`);
    }
  }
  const operatorAfter = journal().filter((j) => j.trigger === 'operator').length;
  out.operator_cycles = operatorAfter - operatorBefore;
  if (operatorAfter - operatorBefore !== (args.allowed ? 1 : 0)) fail(`${operatorAfter - operatorBefore} operator cycles ran, expected ${args.allowed ? 1 : 0}`);

  if (args.shots) {
    fs.mkdirSync(args.shots, { recursive: true });
    await sleep(300);
    await page.screenshot({ path: path.join(args.shots, args.depth ? 'commissioning-page-3d.png' : 'commissioning-page.png'), fullPage: true });
  }
  if (consoleErrors.length) fail('script errors on the page: ' + consoleErrors.join('; '));
  exitCode = failures.length ? 1 : 0;
} catch (e) {
  fail('exception: ' + (e && e.stack || e));
} finally {
  await browser.close().catch(() => {});
}
out.failures = failures;
console.log(JSON.stringify(out));
process.exit(failures.length ? 1 : exitCode);
