// JSON lines over stdin and stdout, shared by the node clients: one command per stdin line,
// one event per stdout line; at the end of stdin the client closes its socket and leaves.
'use strict';

const readline = require('readline');

function emit(event) {
  process.stdout.write(JSON.stringify(event) + '\n');
}

// Run `commands[command.cmd](command)` for each line (then a `done` event, or an `error` one);
// at the end of stdin, `close()` and leave once `ws` closed (or after 2 s).
function serve(commands, ws, close) {
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
    // close cleanly (the server logs an error for a dropped connection), then leave
    ws.on('close', () => process.exit(0));
    close();
    setTimeout(() => process.exit(0), 2000).unref();
  });
}

// Count a message of `bytes` bytes arrived now for a quiet subscription ({count, bytes, first,
// last}: the arrival times in ms).
function tally(counted, bytes) {
  const now = performance.now();
  if (counted.count === 0) {
    counted.first = now;
  }
  counted.last = now;
  counted.count += 1;
  counted.bytes += bytes;
}

// The `stats` event of quiet subscriptions by id: counts, bytes, seconds from the first
// message to the last, and latencies where kept.
function stats(quiet) {
  const counts = {};
  for (const [id, { count, bytes, first, last, latencies }] of quiet) {
    counts[id] = { count, bytes, seconds: (last - first) / 1000, latencies: latencies || [] };
  }
  return { ev: 'stats', counts };
}

module.exports = { emit, serve, stats, tally };
