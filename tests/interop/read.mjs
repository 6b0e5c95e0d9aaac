#!/usr/bin/env node
// An independent reader of plotgate recordings, on the TypeScript MCAP library (@mcap/core,
// the one Foxglove uses), not on Python's `mcap` that wrote them: a bug in one library
// cannot hide behind the same bug in the other.
//
// Usage: node read.mjs [--schemas] FILE.mcap...
// Prints one JSON line per file and exits 0 when every file is a sound plotgate recording,
// 1 when one is not (damaged, truncated, or not what plotgate writes), 2 on bad usage.
//
// A sound recording:
//  - reads from magic to footer with the streaming reader, every chunk's CRC checked, every
//    chunk under MAX_CHUNK_BYTES (256 MiB) uncompressed (a larger declared size is refused before
//    anything is allocated), no record the MCAP spec does not define;
//  - has channels `<operation>/request` and `<operation>/response` (and replay --out's
//    protobuf foxglove.Log `/replay/diff`), json messages, each with
//    a jsonschema schema that is a JSON object schema;
//  - holds messages that are what the recorder writes: a UTF-8 JSON object nested at most
//    MAX_DEPTH deep, with no integer literal of more than MAX_INT_DIGITS digits (Python's
//    json refuses those), a request_id the service could have given and the channel's
//    operation; a request's raw body is text and replay_of an id; a response has an HTTP
//    status, a duration, and a result (status < 400) or an RFC 9457 problem;
//  - when it has a summary (its footer's summary start is not 0: a file the recorder closed
//    but did not compact has none, and is sound as its stream reads): the indexed reader
//    (summary CRC checked) reads back as many messages as the stream, and Statistics counts
//    them too.
// With --schemas the report also carries each topic's schema (parsed JSON).

import { createReadStream } from "node:fs";
import { open, stat } from "node:fs/promises";
import { createRequire } from "node:module";
import { sep } from "node:path";

import * as zstd from "@foxglove/wasm-zstd";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";

const MAX_CHUNK_BYTES = 2 ** 28; // no test writes a chunk near this
const MAX_DEPTH = 256;
const MAX_INT_DIGITS = 4300;
const REQUEST_ID = /^[A-Za-z0-9._:-]{1,128}$/;
const TOPIC = /^([a-z_]+\.[a-z_]+)\/(request|response)$/;
// replay --out's Log of changed exchanges (protobuf foxglove.Log), beside the exchanges.
const DIFF_TOPIC = "/replay/diff";
const DIFF_SCHEMA = { protobuf: "foxglove.Log" };

// wasm-lz4 keeps one decompression context for good, and a frame that fails part-way (a
// bomb) leaves it broken for every later chunk: each file gets a module of its own.
const require = createRequire(import.meta.url);
async function freshLz4() {
  const marker = `${sep}@foxglove${sep}wasm-lz4${sep}`;
  for (const key of Object.keys(require.cache)) if (key.includes(marker)) delete require.cache[key];
  const decompress = require("@foxglove/wasm-lz4");
  await decompress.isLoaded;
  return decompress;
}

function guarded(name, decompress) {
  return (buffer, size) => {
    if (size > BigInt(MAX_CHUNK_BYTES)) {
      throw new Error(`a ${name} chunk declares ${size} bytes uncompressed, over ${MAX_CHUNK_BYTES}`);
    }
    const out = decompress(buffer, Number(size));
    if (out.byteLength !== Number(size)) {
      throw new Error(`a ${name} chunk decompresses to ${out.byteLength} bytes, declares ${size}`);
    }
    return out;
  };
}

// Depth and integer literals, from the JSON text itself (JSON.parse would turn a 5,000-digit
// integer into Infinity without a word).
function textProblem(text) {
  let depth = 0;
  let inString = false;
  let escaped = false;
  let token = "";
  const endToken = () => {
    if (token !== "" && !/[.eE]/.test(token) && token.replace("-", "").length > MAX_INT_DIGITS) {
      return `an integer of ${token.replace("-", "").length} digits`;
    }
    token = "";
    return null;
  };
  for (let i = 0; i < text.length; i++) {
    const c = text[i];
    if (inString) {
      if (escaped) escaped = false;
      else if (c === "\\") escaped = true;
      else if (c === '"') inString = false;
      continue;
    }
    if ((c >= "0" && c <= "9") || c === "-" || c === "+" || c === "." || c === "e" || c === "E") {
      token += c;
      continue;
    }
    const problem = endToken();
    if (problem) return problem;
    if (c === '"') inString = true;
    else if (c === "{" || c === "[") {
      if (++depth > MAX_DEPTH) return `JSON nested deeper than ${MAX_DEPTH} levels`;
    } else if (c === "}" || c === "]") depth--;
  }
  return endToken();
}

function recordProblem(kind, operation, data) {
  let text;
  try {
    text = new TextDecoder("utf-8", { fatal: true, ignoreBOM: true }).decode(data);
  } catch {
    return "not UTF-8";
  }
  const shape = textProblem(text);
  if (shape) return shape;
  let record;
  try {
    record = JSON.parse(text);
  } catch (e) {
    return `not JSON: ${e.message}`;
  }
  if (record === null || typeof record !== "object" || Array.isArray(record)) return "not a JSON object";
  if (typeof record.request_id !== "string" || !REQUEST_ID.test(record.request_id)) return "no request_id";
  if (record.operation !== operation) return `operation ${JSON.stringify(record.operation)} on ${operation}'s channel`;
  if (kind === "request") {
    if ("raw" in record && typeof record.raw !== "string") return "raw is not text";
    if (record.replay_of != null && !REQUEST_ID.test(String(record.replay_of))) return "replay_of is not an id";
    return null;
  }
  const { status, duration_s: duration } = record;
  if (!Number.isInteger(status) || status < 100 || status > 599) return "no HTTP status";
  // a number of seconds in [0, 1e7], as clients/messages.py's MAX_DURATION_S
  if (typeof duration !== "number" || !(duration >= 0 && duration <= 1e7)) return "no duration";
  if (status < 400 && !("result" in record)) return `a ${status} without a result`;
  if (status >= 400 && !isProblem(record.error)) return `a ${status} without a problem`;
  return null;
}

// RFC 9457 problem details as the service writes them (service.schemas.Problem).
function isProblem(p) {
  const text = (v) => typeof v === "string";
  return p !== null && typeof p === "object" && !Array.isArray(p) && text(p.type) &&
    text(p.title) && Number.isInteger(p.status) && text(p.detail) &&
    (p.errors === undefined || (Array.isArray(p.errors) &&
      p.errors.every((e) => e !== null && typeof e === "object" && text(e.field) && text(e.reason))));
}

async function read(file, withSchemas) {
  const errors = [];
  const report = {
    file, ok: false, file_size: 0, truncated: false, summary_present: false, total_messages: 0,
    recovered_messages: 0, first_log_time: null, last_log_time: null, chunks: 0,
    channels: [], json: { messages_checked: 0, invalid: 0, non_object: 0 }, errors,
  };
  try {
    report.file_size = (await stat(file)).size;
  } catch (e) {
    errors.push(`cannot read: ${e.message}`);
    return report;
  }
  const decompressHandlers = {
    lz4: guarded("lz4", await freshLz4()), zstd: guarded("zstd", zstd.decompress),
  };
  const reader = new McapStreamReader({ validateCrcs: true, decompressHandlers, includeChunks: true });
  const schemas = new Map();
  const channels = new Map();
  let summarized = false; // a footer pointing at a summary
  let first;
  let last;
  const onRecord = (rec) => {
    switch (rec.type) {
      case "Schema": {
        if (rec.encoding === "protobuf" && rec.name === "foxglove.Log") {
          schemas.set(rec.id, DIFF_SCHEMA);  // replay --out's /replay/diff
          break;
        }
        let parsed;
        try {
          parsed = JSON.parse(new TextDecoder("utf-8", { fatal: true }).decode(rec.data));
        } catch (e) {
          throw new Error(`schema ${rec.id} (${rec.name}) is not JSON: ${e.message}`);
        }
        if (rec.encoding !== "jsonschema" || parsed?.type !== "object") {
          throw new Error(`schema ${rec.id} (${rec.name}) is not a jsonschema object schema`);
        }
        schemas.set(rec.id, parsed);
        break;
      }
      case "Channel": {
        if (rec.topic === DIFF_TOPIC) {
          if (rec.messageEncoding !== "protobuf" || schemas.get(rec.schemaId) !== DIFF_SCHEMA) {
            throw new Error(`channel ${rec.topic} is not protobuf foxglove.Log`);
          }
          channels.set(rec.id, { id: rec.id, topic: rec.topic, kind: "diff", count: 0 });
          break;
        }
        const topic = TOPIC.exec(rec.topic);
        if (!topic) throw new Error(`channel ${rec.id} (${rec.topic}) is not a plotgate channel`);
        if (rec.messageEncoding !== "json") throw new Error(`channel ${rec.topic} is not json`);
        if (!schemas.has(rec.schemaId)) throw new Error(`channel ${rec.topic} has no schema`);
        if (!channels.has(rec.id)) {
          channels.set(rec.id, { id: rec.id, topic: rec.topic, operation: topic[1], kind: topic[2],
                                 schema: schemas.get(rec.schemaId), count: 0 });
        }
        break;
      }
      case "Message": {
        const ch = channels.get(rec.channelId);
        ch.count++;
        report.total_messages++;
        if (ch.kind === "diff") break;  // a foxglove.Log, not an exchange's record
        report.json.messages_checked++;
        if (first === undefined || rec.logTime < first) first = rec.logTime;
        if (last === undefined || rec.logTime > last) last = rec.logTime;
        const problem = recordProblem(ch.kind, ch.operation, rec.data);
        if (problem) {
          if (problem.startsWith("not JSON") || problem === "not UTF-8") report.json.invalid++;
          else if (problem === "not a JSON object") report.json.non_object++;
          throw new Error(`message ${rec.sequence} on ${ch.topic} at ${rec.logTime} ns: ${problem}`);
        }
        break;
      }
      case "Chunk":
        report.chunks++;
        break;
      case "Footer":
        summarized = rec.summaryStart !== 0n;
        break;
      case "Unknown":
        throw new Error(`a record of opcode ${rec.opcode}, which MCAP does not define`);
      default:
        break;
    }
  };
  let stopped = false;
  try {
    for await (const piece of createReadStream(file, { highWaterMark: 1 << 20 })) {
      reader.append(piece);
      for (let rec; (rec = reader.nextRecord()); ) onRecord(rec);
      if (reader.done()) break;
    }
  } catch (e) {
    stopped = true;
    errors.push(String(e.message ?? e));
  }
  report.recovered_messages = report.total_messages;
  report.first_log_time = first === undefined ? null : String(first);
  report.last_log_time = last === undefined ? null : String(last);
  if (!stopped && !reader.done()) {
    report.truncated = true;
    errors.push(`truncated: no footer; ${report.total_messages} complete messages before the end`);
  }
  if (summarized && !stopped) {
    const handle = await open(file, "r");
    try {
      const indexed = await McapIndexedReader.Initialize({
        readable: new FileHandleReadable(handle), decompressHandlers,
      });
      report.summary_present = true;
      let n = 0;
      for await (const _ of indexed.readMessages({ validateCrcs: true })) n++;
      if (n !== report.total_messages) errors.push(`the index reads ${n} messages, the stream ${report.total_messages}`);
      const stats = indexed.statistics;
      if (stats && stats.messageCount !== BigInt(report.total_messages)) {
        errors.push(`Statistics counts ${stats.messageCount} messages, the stream ${report.total_messages}`);
      }
    } catch (e) {
      errors.push(`indexed reader: ${e.message ?? e}`);
    } finally {
      await handle.close();
    }
  }
  report.channels = [...channels.values()].map(({ schema, operation, kind, ...ch }) =>
    withSchemas ? { ...ch, schema } : ch);
  report.ok = errors.length === 0;
  return report;
}

const args = process.argv.slice(2);
const withSchemas = args.includes("--schemas");
const files = args.filter((a) => a !== "--schemas");
if (files.length === 0 || files.some((f) => f.startsWith("--"))) {
  process.stderr.write("usage: node read.mjs [--schemas] FILE.mcap...\n");
  process.exit(2);
}
await zstd.isLoaded;
let allOk = true;
for (const file of files) {
  const report = await read(file, withSchemas);
  allOk &&= report.ok;
  process.stdout.write(JSON.stringify(report) + "\n");
}
process.exitCode = allOk ? 0 : 1;
