// A lean Foxglove WebSocket client for benchmarks/gateway.py: it counts message frames and
// parses nothing else of them, so that a turn measures the server more than the client.
//
// The same JSON lines as tests/gateway/node/client.js, for the commands a benchmark turn uses
// (subscribe {channelId, quiet}, quiet {subscriptionId}, stats, close) and the events they wait
// on (open, advertise, unadvertise, status, subscribed, stats, done). It uses the `ws` package
// that the tests install in tests/gateway/node, with Node's own Buffers (no ArrayBuffer copy).
//
//   node gateway_counter.js URL
'use strict';

const path = require('path');
const readline = require('readline');
const WebSocket = require(path.join(__dirname, '..', 'tests', 'gateway', 'node', 'node_modules', 'ws'));

const [url] = process.argv.slice(2);
const ws = new WebSocket(url, ['foxglove.sdk.v1']);
const counted = new Map(); // subscription id -> {count, bytes, first, last}
let nextSubscription = 1;

function emit(event) {
  process.stdout.write(JSON.stringify(event) + '\n');
}

ws.on('open', () => emit({ ev: 'open' }));
ws.on('error', (error) => emit({ ev: 'error', message: String(error && error.message) }));
ws.on('close', (code) => emit({ ev: 'close', code }));
ws.on('message', (data, isBinary) => {
  if (isBinary) {
    // message data: opcode 1, subscription id (u32), log time (u64), the message's bytes
    if (data[0] !== 1) {
      return;
    }
    const found = counted.get(data.readUInt32LE(1));
    if (found !== undefined) {
      const now = performance.now();
      if (found.count === 0) {
        found.first = now;
      }
      found.last = now;
      found.count += 1;
      found.bytes += data.length - 13;
    }
    return;
  }
  const message = JSON.parse(data.toString('utf8'));
  if (message.op === 'advertise') {
    emit({ ev: 'advertise', channels: message.channels });
  } else if (message.op === 'unadvertise') {
    emit({ ev: 'unadvertise', channelIds: message.channelIds });
  } else if (message.op === 'status') {
    emit({ ev: 'status', status: message });
  }
});

const commands = {
  subscribe: (c) => {
    const subscriptionId = nextSubscription++;
    ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: subscriptionId, channelId: c.channelId }] }));
    if (c.quiet) {
      commands.quiet({ subscriptionId });
    }
    emit({ ev: 'subscribed', channelId: c.channelId, subscriptionId });
  },
  quiet: (c) => counted.set(c.subscriptionId, { count: 0, bytes: 0, first: 0, last: 0 }),
  stats: () => {
    const counts = {};
    for (const [id, { count, bytes, first, last }] of counted) {
      counts[id] = { count, bytes, seconds: (last - first) / 1000, latencies: [] };
    }
    emit({ ev: 'stats', counts });
  },
  close: () => ws.close(),
};

readline.createInterface({ input: process.stdin }).on('line', (line) => {
  const command = JSON.parse(line);
  try {
    commands[command.cmd](command);
    emit({ ev: 'done', cmd: command.cmd });
  } catch (error) {
    emit({ ev: 'error', message: `${command.cmd}: ${error.message}` });
  }
});
process.stdin.on('end', () => {
  ws.on('close', () => process.exit(0));
  ws.close();
  setTimeout(() => process.exit(0), 2000).unref();
});
