// The web page's static files as `runout serve` serves them (service/src/web_files.cpp, docs/web.md): the
// page at / and /web/, the right types and headers, and every attempt to leave the web root refused —
// "..", percent-encoded dots and slashes, backslashes, and a symlink inside the root that points out of it.
// Raw request paths (node's http.request sends the path as written, without normalising it).
//
//   node tests/web/static.mjs --runout BUILD/runout --web-root BUILD/webroot
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';

const { values: args } = parseArgs({ options: { runout: { type: 'string' }, 'web-root': { type: 'string' } } });
if (!args.runout || !args['web-root']) {
  console.error('static: --runout and --web-root are required');
  process.exit(2);
}

let passed = 0;
const failures = [];
function check(ok, what) {
  if (ok) passed++;
  else failures.push(what);
}

function startServer(dir, extra) {
  fs.mkdirSync(dir, { recursive: true });
  return new Promise((resolve, reject) => {
    const child = spawn(args.runout, ['serve', '--port', '0', '--db', path.join(dir, 'runout.db'), '--runs', path.join(dir, 'runs'),
      '--workers', '0', '--shipped-studies', 'off', ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/listening on http:\/\/([0-9.]+):([0-9]+)/);
      if (m) resolve({ child, host: m[1], port: Number(m[2]), stdout: () => out });
    });
    child.once('exit', (code) => reject(new Error(`runout serve exited (${code}): ${out}`)));
  });
}

function stop(s) {
  return new Promise((resolve) => {
    if (s.child.exitCode !== null) return resolve(s.child.exitCode);
    s.child.once('exit', (code) => resolve(code));
    s.child.kill('SIGTERM');
  });
}

function request(s, method, rawPath) {
  return new Promise((resolve, reject) => {
    const req = http.request({ host: s.host, port: s.port, method, path: rawPath }, (res) => {
      const chunks = [];
      res.on('data', (c) => chunks.push(c));
      res.on('end', () => {
        const body = Buffer.concat(chunks);
        let json = null;
        try {
          json = JSON.parse(body.toString('utf8'));
        } catch {
          /* a file */
        }
        resolve({ status: res.statusCode, headers: res.headers, body, json });
      });
    });
    req.on('error', reject);
    req.setTimeout(30_000, () => req.destroy(new Error(`timeout: ${method} ${rawPath}`)));
    req.end();
  });
}

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'runout-web-static-'));
const servers = [];
try {
  // 1. The built page, served from the default web root next to the binary (the build's webroot/).
  const a = await startServer(path.join(scratch, 'a'), []);
  servers.push(a);
  check(a.stdout().includes(`web page at http://${a.host}:${a.port}/`), `startup line names the page: ${a.stdout()}`);
  const index = fs.readFileSync(path.join(args['web-root'], 'index.html'));
  for (const p of ['/', '/web', '/web/', '/web/index.html']) {
    const r = await request(a, 'GET', p);
    check(r.status === 200, `GET ${p}: ${r.status}`);
    check(r.body.equals(index), `GET ${p} is index.html byte for byte`);
    check(r.headers['content-type'] === 'text/html; charset=utf-8', `GET ${p} type ${r.headers['content-type']}`);
    check(/default-src 'self'/.test(r.headers['content-security-policy'] || ''), `GET ${p} has a CSP that keeps the page to this server`);
    check(r.headers['x-content-type-options'] === 'nosniff', `GET ${p} nosniff`);
  }
  for (const [p, type, file] of [
    ['/web/app.js', 'text/javascript; charset=utf-8', 'app.js'],
    ['/web/style.css', 'text/css; charset=utf-8', 'style.css'],
    ['/web/vendor/uPlot.esm.js', 'text/javascript; charset=utf-8', 'vendor/uPlot.esm.js'],
    ['/web/vendor/uPlot.min.css', 'text/css; charset=utf-8', 'vendor/uPlot.min.css'],
    ['/web/vendor/leaflet-src.esm.js', 'text/javascript; charset=utf-8', 'vendor/leaflet-src.esm.js'],
    ['/web/vendor/leaflet.css', 'text/css; charset=utf-8', 'vendor/leaflet.css'],
    ['/web/vendor/images/layers.png', 'image/png', 'vendor/images/layers.png'],
  ]) {
    const r = await request(a, 'GET', p);
    check(r.status === 200 && r.headers['content-type'] === type, `GET ${p}: ${r.status} ${r.headers['content-type']}`);
    check(r.body.equals(fs.readFileSync(path.join(args['web-root'], file))), `GET ${p} byte for byte`);
  }
  const head = await request(a, 'HEAD', '/web/app.js');
  check(head.status === 200 && head.body.length === 0, `HEAD /web/app.js: ${head.status}, ${head.body.length} bytes`);
  const missing = await request(a, 'GET', '/web/nope.js');
  check(missing.status === 404 && missing.json?.errors?.[0]?.field === 'path', `GET /web/nope.js: ${missing.status} ${missing.body}`);
  const post = await request(a, 'POST', '/web/app.js');
  check(post.status === 405 && /GET/.test(post.headers.allow || ''), `POST /web/app.js: ${post.status} Allow ${post.headers.allow}`);
  const api = await request(a, 'GET', '/api/v1/health');
  check(api.status === 200 && api.json?.status === 'ok', 'the API is still under /api/v1');
  const other = await request(a, 'GET', '/webx');
  check(other.status === 404, `GET /webx is not the page: ${other.status}`);

  // Traversal: refused (400, naming the path) before any file is read.
  const traversals = [
    '/web/../CMakeCache.txt',
    '/web/../../etc/passwd',
    '/web/%2e%2e/%2e%2e/etc/passwd',
    '/web/%2E%2E/runout',
    '/web/..%2f..%2fetc%2fpasswd',
    '/web/vendor/../../CMakeCache.txt',
    '/web/./index.html',
    '/web//etc/passwd',
    '/web/..\\..\\etc\\passwd',
    '/web/%5c..%5c..%5cetc%5cpasswd',
    '/web/%00index.html',
  ];
  for (const p of traversals) {
    const r = await request(a, 'GET', p);
    check(r.status === 400 && r.json?.errors?.[0]?.field === 'path', `GET ${p}: ${r.status} ${r.body.toString().slice(0, 200)}`);
    check(!r.body.toString().includes('root:') && !r.body.toString().includes('CMAKE_'), `GET ${p} leaks nothing`);
  }

  // 2. A web root of our own with a symlink that points out of it: refused; a missing root: 404 with advice.
  const root = path.join(scratch, 'root');
  fs.mkdirSync(path.join(root, 'sub'), { recursive: true });
  fs.writeFileSync(path.join(root, 'index.html'), '<!doctype html><title>t</title>');
  fs.writeFileSync(path.join(scratch, 'secret.txt'), 'TOP-SECRET-CONTENT');
  fs.symlinkSync(path.join(scratch, 'secret.txt'), path.join(root, 'leak.txt'));
  fs.symlinkSync(scratch, path.join(root, 'sub', 'up'));
  fs.writeFileSync(path.join(root, 'sub', 'ok.txt'), 'ok');
  const b = await startServer(path.join(scratch, 'b'), ['--web-root', root]);
  servers.push(b);
  const ok = await request(b, 'GET', '/web/sub/ok.txt');
  check(ok.status === 200 && ok.body.toString() === 'ok', `GET /web/sub/ok.txt from --web-root: ${ok.status}`);
  for (const p of ['/web/leak.txt', '/web/sub/up/secret.txt']) {
    const r = await request(b, 'GET', p);
    check(r.status === 400 && !r.body.toString().includes('TOP-SECRET'), `symlink out of the root ${p}: ${r.status} ${r.body}`);
  }
  const c = await startServer(path.join(scratch, 'c'), ['--web-root', path.join(scratch, 'does-not-exist')]);
  servers.push(c);
  const none = await request(c, 'GET', '/');
  check(none.status === 404 && /--web-root/.test(none.json?.errors?.[0]?.message || ''), `no page: ${none.status} ${none.body}`);
  check(c.stdout().includes('no web page'), `startup line says there is no page: ${c.stdout()}`);
} catch (e) {
  failures.push(String(e.stack || e));
} finally {
  for (const s of servers) check((await stop(s)) === 0, 'runout serve exits 0 on SIGTERM');
  fs.rmSync(scratch, { recursive: true, force: true });
}

for (const f of failures) console.error(`FAILED: ${f}`);
console.log(`${passed} passed, ${failures.length} failed`);
process.exit(failures.length ? 1 : 0);
