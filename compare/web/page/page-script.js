// The engine's own script, named by compare/web/host.py in ?script= (else the page's default, its
// <html data-script>): a module that fails to load (a missing npm package) is reported to the host rather
// than left as a page that never becomes ready.
const script = new URLSearchParams(location.search).get('script') || document.documentElement.dataset.script;
if (!/^[a-z0-9-]+\.js$/.test(script)) window.compareFailed = `no such page script ${script}`;
else import(`./${script}`).catch((e) => { window.compareFailed = String((e && e.message) || e); });
