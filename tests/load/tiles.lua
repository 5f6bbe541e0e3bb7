-- wrk script: 256x256 PNG tiles of one texton (or several, taken in turn). mode "cold": every
-- request a distinct tile (a per-thread walk over a huge grid), mode "warm": the same WARM_SET
-- tiles over and over.
-- Environment: TEXTON (id, or ids separated by commas), MODE (cold|warm), WARM_SET (default 64),
-- SEED, HEADER ("Name: value" added to every request), LEVEL (the tiles' level z, default 0).
local threads = {}
local counter = 0

function setup(thread)
  thread:set("tid", #threads)
  table.insert(threads, thread)
end

function init(args)
  textons = {}
  for id in string.gmatch(os.getenv("TEXTON") or "", "[^,]+") do table.insert(textons, id) end
  local header = os.getenv("HEADER")
  if header and header ~= "" then
    local name, value = string.match(header, "^([^:]+):%s*(.*)$")
    wrk.headers[name] = value
  end
  mode = os.getenv("MODE") or "cold"
  warm_set = tonumber(os.getenv("WARM_SET") or "64")
  seed = os.getenv("SEED") or "0"
  level = os.getenv("LEVEL") or "0"
end

request = function()
  counter = counter + 1
  local x, y
  if mode == "warm" then
    local k = counter % warm_set
    x, y = k % 8, math.floor(k / 8)
  else
    -- distinct per thread and per request: rows far apart per thread
    x, y = counter, tid * 1000003 + 17
  end
  local texton = textons[counter % #textons + 1]
  return wrk.format("GET", "/v1/textons/" .. texton .. "/tiles/" .. level .. "/" .. x .. "/" .. y .. ".png?seed=" .. seed)
end

-- No response() callback: with one, wrk hands every body (197 kB) to Lua, and that copy, not
-- the server, capped the warm phase at ~1,800 tiles/s (0.16x nginx). Non-2xx/3xx answers are
-- counted by wrk itself (summary.errors.status).
done = function(summary, latency, requests)
  io.write(string.format("WRK %d %.1f %.3f %.3f %d %d %d\n", summary.requests,
    summary.requests / (summary.duration / 1e6), latency:percentile(50) / 1000,
    latency:percentile(99) / 1000, summary.errors.connect + summary.errors.read +
    summary.errors.write + summary.errors.timeout, summary.errors.status, summary.bytes))
end
