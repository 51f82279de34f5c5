// What the two views with a state model (PlotView: plot_view.js, Timeline: timeline.js) share in the browser;
// stagger_nb/widgets/_store_view.py puts it before each view's module (an anywidget ESM is one string: it
// cannot import a sibling file).
async function storeOf(model, signal) {
  // the view's state model ("IPY_MODEL_<id>"); during a page reload's restore it may be registered a little
  // after this view's model: ask again until it is (or the view is gone)
  const id = String(model.get("store") || "").replace(/^IPY_MODEL_/, "");
  for (let wait = 100; ; wait = Math.min(2 * wait, 2000)) {
    try {
      return await model.widget_manager.get_model(id);
    } catch (err) {
      if (signal.disposed) throw err;
      await new Promise((r) => setTimeout(r, wait));
    }
  }
}
