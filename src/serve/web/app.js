// aoscan's web page: the live view over WebSocket, the HUD figures, the controls, the sessions
// with their files, and the mesh viewer of a finished session.
import { showMesh } from '/mesh_view.js';

const client = sessionStorage.getItem('aoscan-client') ||
  (crypto.randomUUID ? crypto.randomUUID() : String(Math.random()).slice(2));
sessionStorage.setItem('aoscan-client', client);

const $ = (id) => document.getElementById(id);
const message = (text) => { $('message').textContent = text; };

async function api(method, path, body) {
  const init = { method, headers: { 'X-Aoscan-Client': client } };
  if (body !== undefined) {
    init.headers['Content-Type'] = 'application/json';
    init.body = JSON.stringify(body);
  }
  const response = await fetch(path, init);
  const json = await response.json().catch(() => ({}));
  if (!response.ok) throw new Error(json.error || `${method} ${path}: ${response.status}`);
  return json;
}

// --- live view -------------------------------------------------------------------------------
let socket = null;
let framesShown = 0;
const canvas = $('live');
const context = canvas.getContext('2d');

function connectLive() {
  if (socket) socket.close();
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  socket = new WebSocket(`${scheme}://${location.host}/api/sessions/current/live?view=${$('view').value}`);
  socket.binaryType = 'blob';
  socket.onmessage = async (event) => {
    if (typeof event.data === 'string') {
      showStatus(JSON.parse(event.data));
      return;
    }
    const bitmap = await createImageBitmap(event.data);
    if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas.width = bitmap.width;
      canvas.height = bitmap.height;
    }
    context.drawImage(bitmap, 0, 0);
    bitmap.close();
    framesShown += 1;
    canvas.dataset.frames = String(framesShown);
  };
  socket.onclose = () => { setTimeout(connectLive, 1000); };
}

function row(name, value) {
  const tr = document.createElement('tr');
  const th = document.createElement('th');
  const td = document.createElement('td');
  th.textContent = name;
  td.textContent = value;
  tr.append(th, td);
  return tr;
}

let lastRunning = null;
function showStatus(status) {
  $('service').textContent =
    `version ${status.version}, up ${Math.round(status.uptime_s)} s, ` +
    (status.session ? `session ${status.session} running` : 'no session running') +
    `, ${status.viewers} viewer(s)`;
  $('live-session').textContent = status.session || '';
  const hud = $('hud');
  hud.replaceChildren();
  const state = status.state;
  if (state && state.live) {
    const live = state.live;
    hud.append(row('frames', `${live.frames_processed} fused, ${live.frames_read} read, ${live.frames_dropped} dropped`));
    if (live.fps !== undefined) hud.append(row('fps', live.fps.toFixed(1)));
    if (live.view) {
      hud.append(row('tracking', live.view.tracking));
      for (const { stage, ms } of live.view.stage_ms) hud.append(row(`${stage} ms`, ms.toFixed(1)));
    }
    hud.append(row('integration', live.integration_paused ? 'paused' : 'on'));
  } else if (state) {
    hud.append(row('state', state.state));
  }
  if (lastRunning !== status.session) {
    lastRunning = status.session;
    refreshSessions();
  }
}

$('view').addEventListener('change', () => {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify({ view: $('view').value }));
});

for (const button of document.querySelectorAll('[data-action]')) {
  button.addEventListener('click', async () => {
    const status = await api('GET', '/api/status');
    if (!status.session) { message('no session is running'); return; }
    try {
      await api('POST', `/api/sessions/${status.session}/${button.dataset.action}`);
      message(`${button.dataset.action}: sent`);
    } catch (error) { message(error.message); }
  });
}

// --- new session -----------------------------------------------------------------------------
$('start').addEventListener('submit', async (event) => {
  event.preventDefault();
  const set = {};
  for (const line of $('sets').value.split('\n')) {
    const trimmed = line.trim();
    if (!trimmed) continue;
    const eq = trimmed.indexOf('=');
    if (eq < 1) { message(`"${trimmed}" is not KEY=VALUE`); return; }
    set[trimmed.slice(0, eq).trim()] = trimmed.slice(eq + 1).trim();
  }
  try {
    const started = await api('POST', '/api/sessions', { source: $('source').value, set, realtime: $('realtime').checked });
    message(`session ${started.id} started`);
    refreshSessions();
  } catch (error) { message(error.message); }
});

async function fillSources() {
  const sources = $('sources');
  const [recordings, devices] = await Promise.all([api('GET', '/api/recordings'), api('GET', '/api/devices')]);
  for (const name of [...recordings.recordings, ...devices.devices.map((d) => d.uri), 'synth:corner']) {
    const option = document.createElement('option');
    option.value = name;
    sources.append(option);
  }
}

// --- sessions --------------------------------------------------------------------------------
async function refreshSessions() {
  const { sessions } = await api('GET', '/api/sessions');
  const body = $('sessions').querySelector('tbody');
  body.replaceChildren();
  for (const session of sessions) {
    const tr = document.createElement('tr');
    const cells = [session.id, session.source, session.state].map((text) => {
      const td = document.createElement('td');
      td.textContent = text;
      return td;
    });
    const files = document.createElement('td');
    const view = document.createElement('td');
    if (session.state !== 'running') {
      const detail = await api('GET', `/api/sessions/${session.id}`);
      for (const name of detail.files || []) {
        const a = document.createElement('a');
        a.href = `/api/sessions/${session.id}/files/${name}`;
        a.textContent = name;
        files.append(a, ' ');
      }
      if ((detail.files || []).includes('mesh.ply')) {
        const button = document.createElement('button');
        button.textContent = 'show mesh';
        button.addEventListener('click', () => loadMesh(session.id));
        view.append(button);
      }
    }
    tr.append(...cells, files, view);
    body.append(tr);
  }
}

async function loadMesh(id) {
  $('mesh-name').textContent = id;
  $('mesh-message').textContent = 'loading mesh.ply…';
  try {
    const info = await showMesh($('mesh'), `/api/sessions/${id}/files/mesh.ply`);
    $('mesh-message').textContent = `${info.vertices} vertices, ${info.triangles} triangles; drag to turn, wheel to zoom`;
  } catch (error) {
    $('mesh-message').textContent = error.message;
  }
}

window.aoscan = { loadMesh, refreshSessions };
connectLive();
fillSources().catch((error) => message(error.message));
refreshSessions().catch((error) => message(error.message));
