"""Load test of `tacreasoner serve` on loopback: concurrent clients with the official openai client, with and
without batching, and a burst of malformed requests in between.

Usage:

    python benchmarks/serve_load.py --model runs/quickstart/model --bench runs/quickstart/bench \
        [--clients 8] [--requests 25] [--max-tokens 128] [--bad-clients 4]

For each server setting (batching on: --max-batch 8; off: --max-batch 1) a fresh server process answers
``clients × requests`` real benchmark questions (val split, one-video items; each request carries its clip as a
base64 data URL) twice: once alone, and once while ``bad-clients`` send malformed requests (bad base64, a non-video,
a truncated video, too many videos, placeholders unlike the videos, an unknown model): ``burst`` of them, sent back
to back by ``bad-clients`` clients from the moment the good clients start.
Every good request must succeed and every malformed one must get a 4xx. Reported: p50/p95 latency, throughput
(requests/s and generated tokens/s), and the slowdown of the good requests under the burst (p50 and p95 ratios;
the acceptance bound is 2×). Results: benchmarks/results/serve_load.{json,md}.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import os
import random
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import openai

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

SETTINGS = {"batching on (--max-batch 8)": 8, "batching off (--max-batch 1)": 1}


def _requests(bench: Path, n: int, seed: int) -> list[tuple[str, str]]:
    """(question, data URL of its clip) for ``n`` val items with one whole-clip video."""
    from tacreasoner.serve.media import video_data_url
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(bench, "val")
    root = bench_video_root(bench, info)
    usable = [i for i in items if len(i.videos) == 1 and i.videos[0].start is None and i.videos[0].end is None]
    random.Random(seed).shuffle(usable)
    urls: dict[str, str] = {}
    out = []
    for item in usable[:n]:
        path = str(root / item.videos[0].path)
        urls.setdefault(path, video_data_url(path))
        out.append((item.question, urls[path]))
    return out


def _bad_bodies(good_url: str) -> list[dict[str, Any]]:
    raw = base64.b64decode(good_url.split(",", 1)[1])
    truncated = "data:video/mp4;base64," + base64.b64encode(raw[: len(raw) // 2]).decode()
    video = {"type": "video_url", "video_url": {"url": good_url}}

    def ask(*parts: dict[str, Any], text: str = "Is <tactile> soft?") -> list[dict[str, Any]]:
        return [{"role": "user", "content": [*parts, {"type": "text", "text": text}]}]

    return [
        {"model": "tacreasoner",
         "messages": ask({"type": "video_url", "video_url": {"url": "data:video/mp4;base64,!!"}})},
        {"model": "tacreasoner", "messages": ask({"type": "video_url", "video_url": {
            "url": "data:video/mp4;base64," + base64.b64encode(os.urandom(4000)).decode()}})},
        {"model": "tacreasoner", "messages": ask({"type": "video_url", "video_url": {"url": truncated}})},
        {"model": "tacreasoner", "messages": ask(*[video] * 6, text="<tactile>" * 6)},
        {"model": "tacreasoner", "messages": ask(video, text="Which of <tactile> and <tactile>?")},
        {"model": "gpt-4o", "messages": ask(video)},
    ]


async def _good_client(client: openai.AsyncOpenAI, work: list[tuple[str, str]], max_tokens: int,
                       out: list[dict[str, Any]]) -> None:
    for question, url in work:
        start = time.perf_counter()
        reply = await client.chat.completions.create(
            model="tacreasoner", max_tokens=max_tokens,
            messages=[{"role": "user", "content": [{"type": "video_url", "video_url": {"url": url}},
                                                   {"type": "text", "text": question}]}])
        out.append({"start": start, "latency_s": time.perf_counter() - start, "tokens": reply.usage.completion_tokens,
                    "ok": reply.choices[0].finish_reason in ("stop", "length")})


async def _bad_client(base: str, bodies: list[dict[str, Any]], count: int, codes: list[int],
                      ends: list[float]) -> None:
    async with httpx.AsyncClient(timeout=60) as http:
        for k in range(count):
            response = await http.post(f"{base}/v1/chat/completions", json=bodies[k % len(bodies)])
            codes.append(response.status_code)
    ends.append(time.perf_counter())


async def _run(base: str, work: list[tuple[str, str]], clients: int, max_tokens: int, bad_clients: int,
               burst: int, bodies: list[dict[str, Any]]) -> dict[str, Any]:
    client = openai.AsyncOpenAI(base_url=f"{base}/v1", api_key="none", max_retries=0, timeout=600)
    records: list[dict[str, Any]] = []
    codes: list[int] = []
    ends: list[float] = []
    bad = [asyncio.create_task(_bad_client(base, bodies[c:] + bodies[:c], burst // bad_clients, codes, ends))
           for c in range(bad_clients)] if bad_clients else []
    start = time.perf_counter()
    await asyncio.gather(*[_good_client(client, work[c::clients], max_tokens, records) for c in range(clients)])
    wall = time.perf_counter() - start
    await asyncio.gather(*bad)
    await client.close()
    lat = np.array([r["latency_s"] for r in records])
    # the good requests sent while the burst lasted (all of them in a clean run: the first ones, same count)
    during = [r["latency_s"] for r in records if not ends or r["start"] < max(ends)]
    tokens = sum(r["tokens"] for r in records)
    return {"requests": len(records), "succeeded": sum(r["ok"] for r in records), "wall_s": round(wall, 2),
            "p50_s": round(float(np.percentile(lat, 50)), 3), "p95_s": round(float(np.percentile(lat, 95)), 3),
            "requests_per_s": round(len(records) / wall, 2), "tokens_per_s": round(tokens / wall, 1),
            "mean_tokens": round(tokens / len(records), 1), "malformed_sent": len(codes),
            "malformed_4xx": sum(400 <= c < 500 for c in codes),
            "burst_s": round(max(ends) - start, 2) if ends else None, "during_burst": len(during),
            "during_burst_p50_s": round(float(np.percentile(during, 50)), 3) if during else None}


def _serve(model: Path, port: int, max_batch: int) -> subprocess.Popen:
    server = subprocess.Popen([sys.executable, "-m", "tacreasoner", "serve", "--model", str(model), "--port",
                               str(port), "--max-batch", str(max_batch), "--max-videos", "4"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise RuntimeError(f"the server exited: {server.stderr.read() if server.stderr else ''}")
        try:
            if httpx.get(f"http://127.0.0.1:{port}/health").status_code == 200:
                return server
        except httpx.TransportError:
            time.sleep(0.3)
    raise RuntimeError("the server did not start in 300 s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", type=Path, default=Path("runs/quickstart/model"))
    parser.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--requests", type=int, default=25, help="per client")
    parser.add_argument("--max-tokens", type=int, default=128)
    parser.add_argument("--bad-clients", type=int, default=4)
    parser.add_argument("--burst", type=int, default=400, help="malformed requests in the burst")
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--results-dir", type=Path, default=None)
    parser.add_argument("--name", default="serve_load")
    args = parser.parse_args()
    info = stamp()
    work = _requests(args.bench, args.clients * args.requests, args.seed)
    if len(work) < args.clients * args.requests:
        raise SystemExit(f"{args.bench}: only {len(work)} usable val items for {args.clients * args.requests} requests")
    bodies = _bad_bodies(work[0][1])
    results: dict[str, Any] = {}
    for label, max_batch in SETTINGS.items():
        server = _serve(args.model, args.port, max_batch)
        try:
            base = f"http://127.0.0.1:{args.port}"
            clean = asyncio.run(_run(base, work, args.clients, args.max_tokens, 0, 0, bodies))
            burst = asyncio.run(_run(base, work, args.clients, args.max_tokens, args.bad_clients, args.burst, bodies))
            health = httpx.get(f"http://127.0.0.1:{args.port}/health").json()
        finally:
            server.terminate()
            server.wait(timeout=60)
        results[label] = {"clean": clean, "with_malformed_burst": burst, "server_stats": health,
                          "slowdown_p50": round(burst["p50_s"] / clean["p50_s"], 2),
                          "slowdown_p95": round(burst["p95_s"] / clean["p95_s"], 2),
                          "slowdown_p50_during_burst": round(burst["during_burst_p50_s"] / clean["p50_s"], 2)}
        print(label, results[label], flush=True)
    on, off = (results[k]["clean"] for k in SETTINGS)
    payload = {**info, "model": str(args.model), "bench": str(args.bench), "clients": args.clients,
               "requests_per_client": args.requests, "max_tokens": args.max_tokens,
               "bad_clients": args.bad_clients, "burst": args.burst,
               "results": results, "batching_speedup_requests_per_s": round(on["requests_per_s"] /
                                                                            off["requests_per_s"], 2)}
    rows = []
    for label, r in results.items():
        for phase in ("clean", "with_malformed_burst"):
            x = r[phase]
            rows.append([label, phase.replace("_", " "), f"{x['succeeded']}/{x['requests']}", x["p50_s"], x["p95_s"],
                         x["requests_per_s"], x["tokens_per_s"], x["mean_tokens"],
                         f"{x['malformed_4xx']}/{x['malformed_sent']}" if x["malformed_sent"] else "–"])
    md = header_md("Serving under load: the OpenAI-compatible server on loopback", info)
    md += (f"Model `{args.model}`; {args.clients} concurrent clients × {args.requests} requests (official `openai` "
           f"AsyncOpenAI client; DynTAC-Sim-Bench val questions with one clip each, sent as base64 data URLs; "
           f"max_tokens {args.max_tokens}, greedy). Server and clients share this machine's cores; latency is per "
           f"request, from send to full reply. The malformed burst: {args.burst} bad requests (bad base64, non-video, "
           f"truncated video, too many videos, placeholder mismatch, unknown model) sent back to back by "
           f"{args.bad_clients} more clients from the moment the good clients start.\n\n")
    md += md_table(["server", "run", "succeeded", "p50 s", "p95 s", "requests/s", "tokens/s", "tokens/reply",
                    "malformed → 4xx"], rows)
    md += "\n" + "\n".join(f"- {label}: with the burst the good requests' p50 is {r['slowdown_p50']}× and p95 "
                           f"{r['slowdown_p95']}× the clean run's; the {r['with_malformed_burst']['during_burst']} "
                           f"sent while the burst lasted ({r['with_malformed_burst']['burst_s']} s) have p50 "
                           f"{r['with_malformed_burst']['during_burst_p50_s']} s, "
                           f"{r['slowdown_p50_during_burst']}× the clean p50 (bound: 2×); server, over both runs: "
                           f"{r['server_stats']['calls']} generate calls, largest batch "
                           f"{r['server_stats']['largest_batch']}."
                           for label, r in results.items())
    md += f"\n- Batching raises throughput {payload['batching_speedup_requests_per_s']}× (requests/s, clean runs).\n"
    publish(args.name, payload, md, args.results_dir)


if __name__ == "__main__":
    main()
