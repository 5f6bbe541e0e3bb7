// What the browser tests share: a `textond serve` on a free port, and checks that print and count.
import { spawn } from 'node:child_process';
import { createInterface } from 'node:readline';

// `binary serve` on 127.0.0.1 with DATA: { proc, url } once it listens.
export function startServer(binary, data, extra = []) {
  const proc = spawn(binary, ['serve', '--port', '0', '--data', data, '--backend', 'cpu',
                              '--log-level', 'warn', ...extra], { stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    const lines = createInterface({ input: proc.stdout });
    lines.once('line', (line) => {
      const m = line.match(/listening on (http:\/\/[^ ]+?)\/?$/);
      m ? resolve({ proc, url: m[1] }) : reject(new Error(`server said: ${line}`));
    });
    proc.once('exit', (code) => reject(new Error(`server exited ${code}`)));
  });
}

// check(ok, what) prints "ok" or "FAIL" and keeps what failed in `failures`.
export function checker() {
  const failures = [];
  const check = (ok, what) => {
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
    if (!ok) failures.push(what);
  };
  return { check, failures };
}
