// A pool of module workers sharing one compiled WebAssembly.Module. Requests queue and
// go to an idle worker, or, while many are queued, to a worker with fewer than `DEPTH`
// in flight (a worker answers one request at a time: the next waits in its message
// queue, so the worker does not idle while its reply travels back and a new request
// comes); `all` sends one request to every worker, `to` one to a given worker. A worker
// may send `{ id, progress }` reports before its reply; they go to the request's
// `onProgress`.

/** Requests in flight per worker. */
export const DEPTH = 2;

export class WorkerPool {
  /** @param {WebAssembly.Module} module @param {number} size */
  static async create(module, size) {
    const pool = new WorkerPool(size);
    await Promise.all(pool.workers.map((w) => pool.#send(w, { op: "init", module })));
    return pool;
  }

  constructor(size) {
    this.workers = Array.from({ length: size }, () => {
      const worker = new Worker(new URL("./worker.js", import.meta.url), { type: "module" });
      worker.pending = new Map();
      worker.inFlight = 0;
      worker.onmessage = ({ data }) => {
        const job = worker.pending.get(data.id);
        if (data.progress) {
          job?.onProgress?.(data.progress);
          return;
        }
        worker.pending.delete(data.id);
        if (data.ok) job.resolve(data);
        else job.reject(new Error(data.message));
      };
      worker.onerror = (event) => {
        event.preventDefault();
        for (const job of worker.pending.values()) job.reject(new Error(event.message || "worker failed to start"));
        worker.pending.clear();
      };
      return worker;
    });
    this.queue = [];
    this.nextId = 1;
    /** What every worker's estimator holds after the last complete hand-over of views
     * (set by engine.js), so that the next estimate of the same light field sends none. */
    this.held = null;
  }

  get size() {
    return this.workers.length;
  }

  #send(worker, request, transfer = [], onProgress = undefined) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      worker.pending.set(id, { resolve, reject, onProgress });
      worker.postMessage({ ...request, id }, transfer);
    });
  }

  /** Runs `request` on the first idle worker; `onProgress` gets its progress reports. */
  run(request, transfer = [], onProgress = undefined) {
    return new Promise((resolve, reject) => {
      this.queue.push({ request, transfer, onProgress, resolve, reject });
      this.#dispatch();
    });
  }

  /** Runs `request` on worker `index` (0 ≤ index < size), queue or not. */
  to(index, request, transfer = [], onProgress = undefined) {
    const worker = this.workers[index];
    worker.inFlight++;
    return this.#send(worker, request, transfer, onProgress).finally(() => {
      worker.inFlight--;
      this.#dispatch();
    });
  }

  /** Runs `request` on every worker (each gets its own copy of the data). */
  all(request) {
    return Promise.all(this.workers.map((w) => this.#send(w, request)));
  }

  #dispatch() {
    // Idle workers first; a second request in flight only while the queue holds at least
    // one request per worker, so a lookahead never leaves another worker without work.
    for (let depth = 1; depth <= DEPTH; depth++) {
      for (const worker of this.workers) {
        if (!this.queue.length || (depth > 1 && this.queue.length < this.workers.length)) return;
        if (worker.inFlight >= depth) continue;
        const job = this.queue.shift();
        worker.inFlight++;
        this.#send(worker, job.request, job.transfer, job.onProgress)
          .then(job.resolve, job.reject)
          .finally(() => {
            worker.inFlight--;
            this.#dispatch();
          });
      }
    }
  }

  /** Drops queued requests (in-flight ones finish; their replies are ignored by callers). */
  clear(reason) {
    for (const job of this.queue.splice(0)) job.reject(reason);
  }

  terminate() {
    this.held = null;
    for (const w of this.workers) w.terminate();
  }
}
