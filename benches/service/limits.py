#!/usr/bin/env python3
"""What the service's bounds hold, measured on a running `sable serve`.

    python3 benches/service/limits.py target/release/sable list idle start_from

- list: the server's resident memory during GET /v1/jobs (page of 50) over 50 jobs whose
  scenes are 11 MB each (400,689 listed positions), one call and four at once, and the bytes
  of a page;
- idle: the descriptors the server holds while 20,000 clients (fewer if this process may not
  open as many descriptors) open a connection and send a partial request (REST) or nothing
  (gRPC), and the time /healthz takes meanwhile, over --idle-timeout 5 s;
- start_from: the server's peak resident memory while four submissions at once start from the
  final state of a 300,000-grain job.

Each part starts its own server on a throw-away database and stops it. Standard library only.
"""
import json
import os
import resource
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

HTTP, GRPC = 18090, 18091
BASE = f"http://127.0.0.1:{HTTP}"


def serve(sable, db, *more):
    p = subprocess.Popen(
        [sable, "serve", "--db", db, "--http", f"127.0.0.1:{HTTP}", "--grpc", f"127.0.0.1:{GRPC}", "--no-auth", *more],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    for _ in range(300):
        try:
            urllib.request.urlopen(BASE + "/healthz", timeout=1).read()
            return p
        except Exception:
            time.sleep(0.1)
    p.kill()
    raise SystemExit("sable serve did not start")


def stop(p):
    p.terminate()
    try:
        p.wait(10)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()


def status(pid, key):
    """A field of /proc/PID/status in MB."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def reset_peak(pid):
    with open(f"/proc/{pid}/clear_refs", "w") as f:
        f.write("5")


def request(method, path, body=None, timeout=600):
    data = None if body is None else json.dumps(body).encode()
    r = urllib.request.Request(BASE + path, data=data, method=method, headers={"content-type": "application/json"})
    try:
        with urllib.request.urlopen(r, timeout=timeout) as resp:
            return resp.status, resp.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def material():
    return {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}


def at_once(n, f):
    out = [None] * n
    threads = [threading.Thread(target=lambda k=k: out.__setitem__(k, f(k))) for k in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return out


def part_list(sable, tmp):
    side = 633
    positions = [[1.1e-3 * (i + 1), 1.1e-3 * (j + 1)] for i in range(side) for j in range(side)]
    scene = {
        "name": "list", "dimension": 2, "method": "dem", "materials": {"glass": material()},
        "particles": [{"material": "glass", "count": len(positions), "size": {"kind": "monodisperse", "diameter": 1e-3},
                       "placement": {"kind": "list", "positions": positions}}],
        "container": {"min": [0, 0], "max": [0.7, 0.7], "wall_material": "glass"},
        "stop": {"steps": 10}, "sampling": {"every_steps": 10},
    }
    size = len(json.dumps(scene))
    p = serve(sable, os.path.join(tmp, "list.db"), "--workers", "0")
    try:
        for k in range(50):
            scene["seed"] = k
            code, body = request("POST", "/v1/jobs", scene)
            assert code == 201, (code, body[:300])
        rss0 = status(p.pid, "VmRSS")
        reset_peak(p.pid)
        t0 = time.time()
        code, page = request("GET", "/v1/jobs?page_size=50")
        one = time.time() - t0
        hwm1 = status(p.pid, "VmHWM")
        reset_peak(p.pid)
        pages = at_once(4, lambda _: request("GET", "/v1/jobs?page_size=50"))
        hwm4 = status(p.pid, "VmHWM")
        rss_after = status(p.pid, "VmRSS")
        print(f"list: 50 jobs of {size / 1e6:.1f} MB scenes; a page is {len(page) / 1e3:.1f} kB ({one * 1e3:.0f} ms); "
              f"server resident {rss0:.0f} MB before, peak {hwm1:.0f} MB during one call, {hwm4:.0f} MB during four at once, "
              f"{rss_after:.0f} MB after; pages {[len(b) for _, b in pages]}")
    finally:
        stop(p)


def part_idle(sable, tmp, clients=20_000):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 2 * clients + 1000), hard))
    clients = min(clients, hard - 200)  # this process's own descriptors limit the clients
    p = serve(sable, os.path.join(tmp, "idle.db"), "--workers", "0", "--idle-timeout", "5")
    socks = []
    try:
        fds0 = len(os.listdir(f"/proc/{p.pid}/fd"))
        t0 = time.time()
        for k in range(clients):
            s = socket.socket()
            s.setblocking(True)
            try:
                s.connect(("127.0.0.1", HTTP if k % 2 == 0 else GRPC))
            except OSError as e:
                print(f"idle: connection {k} refused: {e}")
                s.close()
                break
            if k % 2 == 0:
                s.send(b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\n")
            socks.append(s)
        opened = time.time() - t0
        print(f"idle: {len(socks)} clients connected in {opened:.1f} s; server descriptors {fds0} before")
        for _ in range(12):
            fds = len(os.listdir(f"/proc/{p.pid}/fd"))
            t1 = time.time()
            try:
                urllib.request.urlopen(BASE + "/healthz", timeout=10).read()
                health = f"{(time.time() - t1) * 1e3:.0f} ms"
            except Exception as e:
                health = f"failed ({e})"
            print(f"idle: t = {time.time() - t0:5.1f} s: server descriptors {fds}, /healthz {health}")
            time.sleep(1)
    finally:
        for s in socks:
            s.close()
        stop(p)


def part_start_from(sable, tmp, grains=300_000, submissions=4):
    db = os.path.join(tmp, "start.db")
    p = serve(sable, db, "--workers", "1")
    try:
        scene = {
            "name": "big state", "dimension": 2, "method": "dem", "materials": {"glass": material()},
            "particles": [{"material": "glass", "count": grains, "size": {"kind": "monodisperse", "diameter": 1e-3},
                           "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [1.2, 1.2], "wall_material": "glass"},
            "stop": {"steps": 1}, "sampling": {"every_steps": 1},
        }
        code, body = request("POST", "/v1/jobs", scene)
        assert code == 201, (code, body[:300])
        job = json.loads(body)["id"]
        for _ in range(600):
            code, body = request("GET", f"/v1/jobs/{job}")
            if json.loads(body)["state"] in ("succeeded", "failed"):
                break
            time.sleep(1)
        assert json.loads(body)["state"] == "succeeded", body[:500]
        code, state = request("GET", f"/v1/jobs/{job}/state")
    finally:
        stop(p)
    p = serve(sable, db, "--workers", "0")
    try:
        rss0 = status(p.pid, "VmRSS")
        reset_peak(p.pid)
        follow = {"name": "from", "dimension": 2, "method": "dem", "materials": {"glass": material()},
                  "start_from": {"job": job}, "container": {"wall_material": "glass"},
                  "stop": {"steps": 1}, "sampling": {"every_steps": 1}}
        t0 = time.time()
        answers = at_once(submissions, lambda k: request("POST", "/v1/jobs", {**follow, "seed": k}))
        took = time.time() - t0
        codes = [c for c, _ in answers]
        hwm = status(p.pid, "VmHWM")
        print(f"start_from: a final state of {grains} grains is {len(state) / 1e6:.0f} MB; {submissions} submissions at once "
              f"answered {codes} in {took:.1f} s; server resident {rss0:.0f} MB before, peak {hwm:.0f} MB, "
              f"{status(p.pid, 'VmRSS'):.0f} MB after")
        if any(c != 201 for c in codes):
            print(answers[0][1][:500])
    finally:
        stop(p)


def main():
    sable, parts = sys.argv[1], sys.argv[2:] or ["list", "idle", "start_from"]
    tmp = tempfile.mkdtemp(prefix="sable-limits-")
    try:
        for part in parts:
            {"list": part_list, "idle": part_idle, "start_from": part_start_from}[part](sable, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
