// A person's steps in a real Foxglove Studio 1.48 (the harness in ../shared/foxglove-studio: the npm
// @foxglove/studio-base bundle in headless Chromium), as docs/foxglove.md gives them: open a local
// file or a connection from the start dialog, import a layout from the Layouts sidebar, or turn on
// every topic of the 3D panel; then screenshots. The file pickers are the browser's: a step hands
// the picker the file the person would pick (fetched from the harness's server), nothing else.
//
//   NODE_PATH=<harness>/node_modules node foxglove_studio_steps.js STUDIO_URL LOG_FILE STEP...
//
// STEP: open-file=URL | connect=WS_URL | import-layout=URL | show-all | hold=N,MS |
// publish-pose=FX,FY,TX,TY | see=TEXT | wait=S | seek=FRACTION | shot=FILE.png | sidebar=KEY |
// shots-until=DIR (screenshots DIR/shot-N.png, one after another, until the file DIR/enough appears:
// the caller looks at each and says when one shows what it waits for; at most 300). Each
// step's outcome goes to LOG_FILE (with STEPS_DEBUG=1 also the browser's console and the text frames
// and message data the page sends over WebSockets); the exit code is 0 when every step was carried out.

"use strict";
const { chromium } = require("playwright-core");
const { execSync } = require("child_process");
const fs = require("fs");

const [studio, logFile, ...steps] = process.argv.slice(2);
const log = [];
const t0 = Date.now();
const say = (line) => log.push(`${((Date.now() - t0) / 1000).toFixed(1)} ${line}`);

async function pick(page, url) {
  // the next showOpenFilePicker() answers with this file, as a person choosing it would
  await page.evaluate((u) => { window.__quadsimPick = u; }, url);
}

async function run(page, step) {
  const [name, value] = step.split(/=(.*)/s);
  if (name === "open-file") {
    await pick(page, value);
    await page.getByText("Open local file", { exact: true }).first().click();
  } else if (name === "connect") {
    await page.getByText("Open connection", { exact: true }).first().click();
    const field = page.getByLabel("WebSocket URL").first();
    await field.fill(value);
    await page.getByRole("button", { name: "Open", exact: true }).click();
  } else if (name === "import-layout") {
    await pick(page, value);
    await page.locator('[data-sidebar-key="layouts"]').click();
    await page.getByRole("button", { name: "Import layout" }).click();
    await page.getByText(value.split("/").pop().replace(/\.json$/, ""), { exact: true }).first().waitFor();
  } else if (name === "show-all") {
    // the 3D panel's settings (the gear in its toolbar: the first panel's), then the menu of the
    // Topics node -> Show All
    await page.locator('[data-testid="SettingsIcon"]').first().click();
    const topics = page.getByText("Topics", { exact: true }).first();
    await topics.waitFor();
    const row = topics.locator('xpath=ancestor::*[.//button[@data-testid="node-actions-menu-button"]][1]');
    await row.locator('[data-testid="node-actions-menu-button"]').first().click();
    await page.getByRole("menuitem", { name: "Show All" }).click();
  } else if (name === "sidebar") {
    // open or close a sidebar by its key: connection (Data source), layouts, panel-settings...
    await page.locator(`[data-sidebar-key="${value}"]`).click();
  } else if (name === "hold") {
    // hold a Teleop panel's button down: N counts the buttons of every Teleop panel in the layout's
    // order (each panel's up, down, left, right)
    const [index, ms] = value.split(",").map(Number);
    const box = await page.locator('svg[viewBox="0 0 256 256"] g[role=button]').nth(index).locator("path").first().boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    await page.waitForTimeout(ms);
    await page.mouse.up();
  } else if (name === "publish-pose") {
    // the 3D panel's publish tool as a person uses it in Studio 1.48: hold its button (in the
    // panel's toolbar) for its menu, choose "Publish pose" (that starts the tool), click the place
    // on the ground, then click again toward the heading (the tool takes two clicks; a drag turns
    // the camera instead). FX,FY then TX,TY: the two clicks, in fractions of the panel's canvas
    const [fx, fy, tx, ty] = value.split(",").map(Number);
    const button = page.locator('[data-testid="publish-button"]').first();
    const b = await button.boundingBox();
    await page.mouse.move(b.x + b.width / 2, b.y + b.height / 2);
    await page.mouse.down();
    await page.waitForTimeout(800);
    await page.mouse.up();
    await page.getByRole("menuitem", { name: "Publish pose", exact: true }).click();
    const box = await page.locator("canvas").first().boundingBox(); // the layout's first panel is the 3D
    const at = [box.x + box.width * fx, box.y + box.height * fy];
    // once the menu (and its backdrop, which takes a click) is gone from where the person clicks
    await page.waitForFunction(([x, y]) => document.elementFromPoint(x, y)?.tagName === "CANVAS", at);
    await page.mouse.click(...at);
    await page.mouse.move(box.x + box.width * tx, box.y + box.height * ty, { steps: 5 });
    await page.mouse.click(box.x + box.width * tx, box.y + box.height * ty);
    // published: the tool is done (when it missed a click it still waits for one, "Click to cancel")
    await page.locator('[data-testid="publish-button"][title="Click to publish"]').waitFor({ timeout: 10000 });
  } else if (name === "see") {
    // wait until the page shows TEXT (e.g. a line of the Log panel)
    await page.getByText(value).first().waitFor();
  } else if (name === "wait") {
    await page.waitForTimeout(Number(value) * 1000);
  } else if (name === "seek") {
    const box = await page.locator('[class*="Slider-root"]').first().boundingBox();
    await page.mouse.click(box.x + box.width * Number(value), box.y + box.height / 2);
  } else if (name === "shot") {
    await page.mouse.move(1, 999);
    await page.screenshot({ path: value, timeout: 240000 });
  } else if (name === "shots-until") {
    await page.mouse.move(1, 999);
    for (let n = 0; !fs.existsSync(`${value}/enough`); n++) {
      if (n >= 300) throw new Error("300 screenshots and none showed what the caller waits for");
      await page.screenshot({ path: `${value}/.shot-${n}.png`, timeout: 240000 });
      fs.renameSync(`${value}/.shot-${n}.png`, `${value}/shot-${n}.png`); // whole when it appears
      await page.waitForTimeout(250);
    }
  } else {
    throw new Error(`unknown step ${step}`);
  }
}

(async () => {
  const executablePath = process.env.CHROMIUM || execSync("command -v chromium").toString().trim();
  const browser = await chromium.launch({
    executablePath,
    headless: true,
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--enable-webgl"],
  });
  let failed = false;
  try {
    const page = await browser.newPage({ viewport: { width: 1600, height: 1000 } });
    page.setDefaultTimeout(120000);
    page.on("pageerror", (e) => say(`[pageerror] ${e.message.slice(0, 300)}`));
    page.on("console", (m) => { if (m.type() === "error" || process.env.STEPS_DEBUG) say(`[console.${m.type()}] ${m.text().slice(0, 300)}`); });
    if (process.env.STEPS_DEBUG) {
      page.on("websocket", (w) => w.on("framesent", (f) => {
        const p = f.payload; // a message's data: opcode 1, the channel id (u32), the message
        const text = typeof p === "string" ? p : `data on channel ${p.readUInt32LE(1)}: ${p.subarray(5).toString("latin1")}`;
        say(`[ws sent] ${text.slice(0, 600)}`);
      }));
    }
    await page.addInitScript(() => {
      window.showOpenFilePicker = async () => {
        const url = window.__quadsimPick;
        window.__quadsimPick = undefined;
        if (!url) { throw new DOMException("no file chosen", "AbortError"); }
        const blob = await (await fetch(url)).blob();
        const name = decodeURIComponent(new URL(url, location.href).pathname.split("/").pop());
        const file = new File([blob], name, { type: name.endsWith(".json") ? "application/json" : "" });
        const granted = async () => "granted";
        return [{ kind: "file", name, getFile: async () => file, queryPermission: granted, requestPermission: granted }];
      };
    });
    await page.goto(studio, { timeout: 240000 });
    await page.getByText("Open data source").first().waitFor({ timeout: 240000 });
    for (const step of steps) {
      try {
        await run(page, step);
        say(`[done] ${step}`);
      } catch (e) {
        failed = true;
        say(`[failed] ${step}: ${e.message.split("\n")[0]}`);
      }
    }
    let text = "";
    try { text = await page.evaluate(() => document.body.innerText.slice(0, 4000)); } catch (e) { /* page gone */ }
    log.push("", "=== page text ===", text);
  } finally {
    fs.writeFileSync(logFile, log.join("\n") + "\n");
    await browser.close();
  }
  process.exit(failed ? 1 : 0);
})().catch((e) => { console.error("FAILED", e); process.exit(2); });
