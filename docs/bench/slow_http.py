#!/usr/bin/env python3
"""A slow static HTTP server for benchmarks of remote stores (docs/benchmarks.md): serves a
folder on 127.0.0.1 with LATENCY seconds added to every request and all bodies sharing one link
of BANDWIDTH bytes a second. Serves single byte ranges (`Range: bytes=A-B`, `bytes=A-`,
`bytes=-N`), as object stores do. Counts requests and bytes, the most requests in flight at
once, the seconds from the first request's arrival to the last answer's end (`active_s`) and
the round trips one after another (`waves`: the longest chain of requests each of which arrived
after the one before it was answered), printed when stopped: a client that keeps the link full
makes few waves, one that waits for each batch before asking the next makes many. Also the
distinct paths and `Range` headers answered (`distinct`): requests beyond them fetched the same
bytes again (the same bytes asked for under another range count apart). And the link over
time: per 50 ms from the first request, the requests that arrived and the MB sent, and the first
40 requests' arrival and path (the round trips of an open).

Usage: slow_http.py ROOT PORT LATENCY_S BANDWIDTH_BYTES_PER_S
"""
import http.server
import os
import signal
import sys
import threading
import time

root, port, latency, bandwidth = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
lock = threading.Lock()
link_free_at = [0.0]
counts = {"requests": 0, "bytes": 0, "peak_in_flight": 0}
in_flight = [0]
# (arrival, end) of every answered GET.
spans = []
# (path, range) of every GET answered with bytes.
asked = set()
# (arrival, path) of every GET, and (time, bytes) of every piece of a body written.
arrivals = []
sent = []


def reserve(nbytes):
    """When the shared link has sent `nbytes` more (a token bucket of one link)."""
    with lock:
        start = max(time.monotonic(), link_free_at[0])
        link_free_at[0] = start + nbytes / bandwidth
        return link_free_at[0]


class Handler(http.server.SimpleHTTPRequestHandler):
    # Connections kept alive, as object stores and web servers keep them.
    protocol_version = "HTTP/1.1"
    # Each answer is written as its headers and then its body. With Nagle's algorithm on (the
    # socket's default), the body waited for the client's ACK of the headers, which Linux
    # delays by 40 ms: every request took LATENCY + ~40 ms (runs up to 80). Object stores and
    # web servers (nginx's `tcp_nodelay`) send without that wait.
    disable_nagle_algorithm = True

    def __init__(self, *args, **kwargs):
        super().__init__(*args, directory=root, **kwargs)

    def log_message(self, *args):
        pass

    def do_GET(self):
        arrived = time.monotonic()
        with lock:
            arrivals.append((arrived, self.path))
            in_flight[0] += 1
            counts["peak_in_flight"] = max(counts["peak_in_flight"], in_flight[0])
        try:
            self.answer()
        finally:
            with lock:
                in_flight[0] -= 1
                spans.append((arrived, time.monotonic()))

    def answer(self):
        time.sleep(latency)
        path = self.translate_path(self.path)
        if not os.path.isfile(path):
            self.send_error(404)
            return
        # Only the bytes asked for are read, as an object store does: reading a 75 MB shard
        # whole for each range of it kept the link idle while this process read (issue 54).
        size = os.path.getsize(path)
        start, end = 0, size - 1
        status, extra = 200, {}
        wanted = self.headers.get("Range", "")
        if wanted.startswith("bytes=") and "," not in wanted:
            first, _, last = wanted[6:].partition("-")
            if first == "":
                start, end = max(size - int(last), 0), size - 1
            else:
                start = int(first)
                end = min(int(last), size - 1) if last else size - 1
            if start >= size or start > end:
                self.send_response(416)
                self.send_header("Content-Range", f"bytes */{size}")
                self.send_header("Content-Length", "0")
                self.end_headers()
                return
            status, extra = 206, {"Content-Range": f"bytes {start}-{end}/{size}"}
        with open(path, "rb") as f:
            f.seek(start)
            body = f.read(end + 1 - start)
        with lock:
            counts["requests"] += 1
            counts["bytes"] += len(body)
            asked.add((self.path, wanted))
        self.send_response(status)
        for key, value in extra.items():
            self.send_header(key, value)
        self.send_header("Accept-Ranges", "bytes")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        for i in range(0, len(body), 65536):
            piece = body[i:i + 65536]
            wait = reserve(len(piece)) - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            self.wfile.write(piece)
            with lock:
                sent.append((time.monotonic(), len(piece)))

    def do_HEAD(self):
        time.sleep(latency)
        super().do_HEAD()


class Server(http.server.ThreadingHTTPServer):
    # socketserver's default backlog is 5: a client opening 32 connections at once had the
    # rest of its SYNs dropped and resent after 1 s (runs 52-53 waited on that too).
    request_queue_size = 1024
    daemon_threads = True


server = Server(("127.0.0.1", port), Handler)
# `kill` (SIGTERM) stops it through the `finally` below, so the counts are printed.
signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
try:
    server.serve_forever()
finally:
    with lock:
        spans.sort()
        if spans:
            counts["active_s"] = round(max(e for _, e in spans) - spans[0][0], 3)
            # depth[i]: the longest chain ending with request i (answers end in order of
            # arrival closely enough to bound the search by the ends seen so far).
            depth = []
            for i, (start, _) in enumerate(spans[:20000]):
                before = [depth[j] for j in range(i) if spans[j][1] <= start]
                depth.append(1 + max(before, default=0))
            counts["waves"] = max(depth)
        counts["distinct"] = len(asked)
    print("served", counts, file=sys.stderr)
    if arrivals:
        # The link over time: per 50 ms from the first request, the requests that arrived and
        # the MB sent; and the first requests' paths, which show the open's round trips.
        t0 = min(t for t, _ in arrivals)
        bins = int((max([t for t, _ in sent] + [t for t, _ in arrivals]) - t0) / 0.05) + 1
        asks, mb = [0] * bins, [0.0] * bins
        for t, _ in arrivals:
            asks[int((t - t0) / 0.05)] += 1
        for t, n in sent:
            mb[int((t - t0) / 0.05)] += n / 1e6
        print("timeline per 50 ms: requests", asks, file=sys.stderr)
        print("timeline per 50 ms: MB", [round(x, 2) for x in mb], file=sys.stderr)
        first = sorted(arrivals)[:40]
        print("first requests:", " ".join(f"{t - t0:.3f}:{path}" for t, path in first),
              file=sys.stderr)
