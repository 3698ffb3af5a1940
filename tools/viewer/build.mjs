// Builds the viewer bundle: src/main.js and three.js bundled and minified by esbuild, inlined
// into src/index.html, written to ../../target/viewer/replay-template.html (or argv[2]).
// `sim-host view` fills the template's data placeholder with a run (docs/viewer.md).
import { build } from 'esbuild';
import { readFileSync, writeFileSync, mkdirSync } from 'node:fs';
import { dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const out = resolve(process.argv[2] || resolve(here, '../../target/viewer/replay-template.html'));
const r = await build({
  entryPoints: [resolve(here, 'src/main.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: 'es2020',
  write: false,
  legalComments: 'eof',
});
// Inside an inline <script>, "</script" would end it.
const js = r.outputFiles[0].text.replaceAll('</script', '<\\/script');
if (js.includes('__ACS_REPLAY_DATA__')) throw new Error('the bundle contains the data placeholder');
const html = readFileSync(resolve(here, 'src/index.html'), 'utf8');
const marker = '/*__ACS_VIEWER_BUNDLE__*/';
if (html.split(marker).length !== 2) throw new Error('src/index.html must hold the bundle marker once');
const page = html.replace(marker, () => js);
mkdirSync(dirname(out), { recursive: true });
writeFileSync(out, page);
console.log(`viewer bundle: ${out} (${page.length} bytes)`);
