// Fails, naming both versions, when the node that runs the browser test is older than the
// installed playwright-core accepts (its package.json "engines.node", a ">=X[.Y[.Z]]" range).
// Written in plain CommonJS so that it runs, and explains itself, on any node old or new.
//   node check_node.cjs [BROWSER_TEST_DIR]      (default: the directory of this file)
"use strict";
var fs = require("fs");
var path = require("path");

var dir = process.argv[2] || __dirname;
var driverJson = path.join(dir, "node_modules", "playwright-core", "package.json");
if (!fs.existsSync(driverJson)) {
  console.error("FAIL: " + driverJson + " is missing: the browser test's driver is not installed " +
                "(scripts/setup_browser_test.sh runs `npm ci` in tests/browser)");
  process.exit(1);
}
var driver = JSON.parse(fs.readFileSync(driverJson, "utf8"));
var range = (driver.engines && driver.engines.node) || "";
var match = /^\s*>=\s*v?(\d+)(?:\.(\d+))?(?:\.(\d+))?\s*$/.exec(range);
if (!match) {
  console.error("FAIL: playwright-core " + driver.version + " asks for node '" + range +
                "', which this check cannot read (it knows '>=X.Y.Z' only)");
  process.exit(1);
}
var need = [Number(match[1]), Number(match[2] || 0), Number(match[3] || 0)];
var have = process.versions.node.split(".").map(Number);
var older = false;
for (var i = 0; i < 3; i++) {
  if (have[i] !== need[i]) {
    older = have[i] < need[i];
    break;
  }
}
if (older) {
  console.error("FAIL: node " + process.versions.node + " (" + process.execPath + ") is older " +
                "than playwright-core " + driver.version + " requires (node " + range + "); pin " +
                "a driver version whose engines.node accepts it in tests/browser/package.json, " +
                "or install a newer node");
  process.exit(1);
}
console.log("ok: node " + process.versions.node + " satisfies playwright-core " + driver.version +
            " (node " + range + ")");
