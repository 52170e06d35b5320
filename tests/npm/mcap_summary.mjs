// Reads an MCAP file with the MCAP reference reader (@mcap/core) and decodes every message with
// Foxglove's ROS 2 readers (@foxglove/rosmsg parses each schema, @foxglove/rosmsg2-serialization
// decodes the CDR), then prints one JSON line: what a third-party tool sees in our field logs.
//
//   node mcap_summary.mjs FILE
//
// A whole file is read through its summary and index (McapIndexedReader); a file without a usable
// summary (a log cut by a kill) is streamed record by record with CRC checks (McapStreamReader) up
// to where it ends. Exit 1 with a message when a reader fails on the readable part.
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { readFileSync } from "fs";

const file = process.argv[2];
const buf = readFileSync(file);
const out = { file, bytes: buf.length, indexed: false, schemas: {}, counts: {}, decoded: 0, first: {} };
const readers = new Map();  // schema id -> MessageReader

function decode(schema, channel, message) {
  if (!readers.has(schema.id)) {
    if (schema.encoding !== "ros2msg") throw new Error(`schema ${schema.name}: encoding ${schema.encoding}`);
    const text = new TextDecoder().decode(schema.data);
    readers.set(schema.id, new MessageReader(parse(text, { ros2: true })));
  }
  const value = readers.get(schema.id).readMessage(message.data);
  out.decoded++;
  const topic = channel.topic;
  out.schemas[topic] = schema.name;
  out.counts[topic] = (out.counts[topic] || 0) + 1;
  if (!(topic in out.first)) {
    // A few fields of the first message of each topic, to check the decoding.
    const f = {};
    if (value.format !== undefined) f.format = value.format;
    if (value.encoding !== undefined) f.encoding = value.encoding;
    if (value.width !== undefined) f.width = value.width;
    if (value.k !== undefined) f.k = Array.from(value.k);
    if (value.timestamp !== undefined) f.sec = value.timestamp.sec;
    if (value.pose !== undefined) f.w = value.pose.orientation.w;
    if (value.message !== undefined) f.message = value.message;
    if (value.data !== undefined) f.data_bytes = value.data.length;
    if (value.point_stride !== undefined) f.point_stride = value.point_stride;
    if (value.fields !== undefined) f.fields = value.fields.map((x) => x.name);
    out.first[topic] = f;
  }
}

try {
  const readable = {
    size: async () => BigInt(buf.length),
    read: async (offset, length) => buf.subarray(Number(offset), Number(offset + length)),
  };
  const reader = await McapIndexedReader.Initialize({ readable });
  out.indexed = true;
  out.statistics = Number(reader.statistics?.messageCount ?? -1);
  out.chunks = reader.chunkIndexes.length;
  for await (const m of reader.readMessages()) {
    const channel = reader.channelsById.get(m.channelId);
    decode(reader.schemasById.get(channel.schemaId), channel, m);
  }
} catch (e) {
  if (out.indexed) {
    console.error(`${file}: ${e.message}`);
    process.exit(1);
  }
  // No usable summary: stream it.
  out.indexed_error = String(e.message);
  out.decoded = 0;
  out.counts = {};
  const stream = new McapStreamReader({ validateCrcs: true });
  stream.append(buf);
  const schemas = new Map(), channels = new Map();
  let rec;
  try {
    while ((rec = stream.nextRecord())) {
      if (rec.type === "Schema") schemas.set(rec.id, rec);
      else if (rec.type === "Channel") channels.set(rec.id, rec);
      else if (rec.type === "Message") {
        const channel = channels.get(rec.channelId);
        decode(schemas.get(channel.schemaId), channel, rec);
      }
    }
  } catch (e2) {
    console.error(`${file}: streaming: ${e2.message}`);
    process.exit(1);
  }
  out.stream_done = stream.done();
}
console.log(JSON.stringify(out));
