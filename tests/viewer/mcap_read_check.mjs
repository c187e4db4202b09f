// Reads an MCAP file with the mcap library's own readers (@mcap/core: McapIndexedReader through
// the summary and chunk indexes, McapStreamReader front to back with every CRC checked; zstd
// chunks through fzstd) and prints what both saw as JSON: schemas, channels, messages per topic,
// the first and last log time per topic, and whether every JSON message parsed. Exits 1 on any
// read error or when the two readers disagree.
// Usage: node mcap_read_check.mjs FILE.mcap   (packages from viewer/web/node_modules, or from
//        $KESTREL_NODE_MODULES)
import { open, readFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
const modules =
  process.env.KESTREL_NODE_MODULES ?? path.join(here, "..", "..", "viewer", "web", "node_modules");
const require = createRequire(path.join(modules, "noop.js"));
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");
const fzstd = require("fzstd");

const file = process.argv[2];
const decompressHandlers = {
  zstd: (buffer, decompressedSize) => {
    const out = fzstd.decompress(buffer);
    if (BigInt(out.length) !== decompressedSize) throw new Error("zstd: wrong decompressed size");
    return out;
  },
};

function summarize(schemas, channels, messages) {
  const topics = {};
  let jsonErrors = 0;
  const decoder = new TextDecoder();
  for (const m of messages) {
    const channel = channels.get(m.channelId);
    const t = (topics[channel.topic] ??= { count: 0, first: null, last: null });
    t.count += 1;
    const time = m.logTime.toString();
    if (t.first === null || m.logTime < BigInt(t.first)) t.first = time;
    if (t.last === null || m.logTime > BigInt(t.last)) t.last = time;
    try {
      JSON.parse(decoder.decode(m.data));
    } catch {
      jsonErrors += 1;
    }
  }
  // Topics in name order: the indexed reader yields messages by time, the stream reader in file
  // order, so their first appearances may differ.
  const sortedTopics = Object.fromEntries(Object.keys(topics).sort().map((k) => [k, topics[k]]));
  return {
    schemas: [...schemas.values()].map((s) => ({ id: s.id, name: s.name, encoding: s.encoding }))
      .sort((a, b) => a.id - b.id),
    channels: [...channels.values()]
      .map((c) => ({ id: c.id, topic: c.topic, encoding: c.messageEncoding,
                     schema: schemas.get(c.schemaId)?.name ?? null }))
      .sort((a, b) => a.id - b.id),
    topics: sortedTopics,
    jsonErrors,
  };
}

async function indexed() {
  const handle = await open(file, "r");
  const readable = {
    size: async () => BigInt((await handle.stat()).size),
    read: async (offset, size) => {
      const buffer = new Uint8Array(Number(size));
      await handle.read(buffer, 0, Number(size), Number(offset));
      return buffer;
    },
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const messages = [];
  for await (const m of reader.readMessages()) messages.push(m);
  await handle.close();
  const result = summarize(reader.schemasById, reader.channelsById, messages);
  result.chunks = reader.chunkIndexes.length;
  result.statisticsMessageCount = reader.statistics?.messageCount.toString() ?? null;
  return result;
}

async function streamed() {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(new Uint8Array(await readFile(file)));
  const schemas = new Map();
  const channels = new Map();
  const messages = [];
  let footer = false;
  for (let record; (record = reader.nextRecord()) !== undefined; ) {
    if (record.type === "Schema") schemas.set(record.id, record);
    if (record.type === "Channel") channels.set(record.id, record);
    if (record.type === "Message") messages.push(record);
    if (record.type === "Footer") footer = true;
  }
  if (!reader.done()) throw new Error("the stream reader did not reach the end of the file");
  if (!footer) throw new Error("no Footer record");
  return summarize(schemas, channels, messages);
}

try {
  const a = await indexed();
  const b = await streamed();
  const same = JSON.stringify({ ...a, chunks: 0, statisticsMessageCount: 0 }) ===
    JSON.stringify({ ...b, chunks: 0, statisticsMessageCount: 0 });
  console.log(JSON.stringify({ indexed: a, agree: same }, null, 1));
  if (!same) {
    console.error("the indexed and the stream reader disagree:", JSON.stringify(b));
    process.exit(1);
  }
} catch (e) {
  console.error(`mcap_read_check: ${file}: ${e.stack ?? e}`);
  process.exit(1);
}
