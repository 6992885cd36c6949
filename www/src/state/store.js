// The page's work kept in this browser (IndexedDB; nothing leaves the machine): the loaded scans
// in one store, written once each (millions of points are not copied again when a sensor is
// renamed), and one session record beside them (which scan is which sensor and frame, the rig,
// the settings, the last result). Every call resolves, also where storage is refused (a private
// window, a full disk): the page then works as before, without keeping anything.

const DB = 'gmmcalib';
const VERSION = 1;
const SCANS = 'scans';
const SESSION = 'session';
const KEY = 'current';

let opened = null;
const stored = new Set(); // ids of the scans in the store

function open() {
  opened ??= new Promise((resolve, reject) => {
    const request = indexedDB.open(DB, VERSION);
    request.onupgradeneeded = () => {
      request.result.createObjectStore(SCANS, { keyPath: 'id' });
      request.result.createObjectStore(SESSION);
    };
    request.onsuccess = () => resolve(request.result);
    request.onerror = () => reject(request.error);
  }).catch(() => null);
  return opened;
}

// Runs `work(stores)` in one transaction over both stores; resolves to what it returns, or null
// when there is no storage.
async function transaction(mode, work) {
  const db = await open();
  if (!db) return null;
  return new Promise((resolve) => {
    const tx = db.transaction([SCANS, SESSION], mode);
    let out = null;
    tx.oncomplete = () => resolve(out);
    tx.onerror = tx.onabort = () => resolve(null);
    Promise.resolve(work({ scans: tx.objectStore(SCANS), session: tx.objectStore(SESSION) })).then((value) => (out = value));
  });
}

const result = (request) => new Promise((resolve) => {
  request.onsuccess = () => resolve(request.result);
  request.onerror = () => resolve(null);
});

// Keeps `scans` ({id, points, ...}): writes those not kept yet, forgets those kept no more;
// then `session` (a plain, cloneable record). Resolves to true when kept.
export async function save(scans, session) {
  const ids = new Set(scans.map((s) => s.id));
  const done = await transaction('readwrite', (s) => {
    for (const id of stored) if (!ids.has(id)) s.scans.delete(id);
    for (const scan of scans) if (!stored.has(scan.id)) s.scans.put(scan);
    s.session.put(session, KEY);
    return true;
  });
  if (done) {
    stored.clear();
    ids.forEach((id) => stored.add(id));
    flag(true);
  }
  return Boolean(done);
}

// Whether anything is kept, in localStorage: a visit with nothing kept does not touch IndexedDB
// on opening (in the bench, opening it delayed a demo clicked at once by 0.2 s on 2 busy cores).
const FLAG = 'gmmcalib.kept';
const flag = (on) => {
  try {
    if (on) localStorage.setItem(FLAG, '1');
    else localStorage.removeItem(FLAG);
  } catch { /* storage refused: nothing is kept anyway */ }
};
const flagged = () => {
  try {
    return localStorage.getItem(FLAG) === '1';
  } catch {
    return false;
  }
};

// {session, scans} as kept, or null when nothing is.
export async function load() {
  if (!flagged()) return null;
  const kept = await transaction('readonly', async (s) => {
    // Both asked at once: the transaction stays open while a request is pending.
    const [session, scans] = [result(s.session.get(KEY)), result(s.scans.getAll())];
    return { session: await session, scans: await scans };
  });
  if (!kept?.session) return null;
  kept.scans.forEach((scan) => stored.add(scan.id));
  return kept;
}

// Forgets everything kept.
export async function clear() {
  flag(false);
  await transaction('readwrite', (s) => {
    s.scans.clear();
    s.session.clear();
  });
  stored.clear();
}
