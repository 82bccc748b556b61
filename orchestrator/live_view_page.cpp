// The live view's page, embedded in the binary: plain HTML + JavaScript + SVG, no build step, no
// external resources. The page is live_view/page.html; orchestrator/CMakeLists.txt embeds it as a string
// (live_view_page_html.hpp, generated). It polls state.json (live_view.hpp) and redraws. Once a snapshot is
// drawn the body carries data-agents (agents drawn), data-step, data-done and data-rmse (the RMSE as shown),
// which the headless-Chromium test reads.
#include "live_view.hpp"
#include "live_view_page_html.hpp"

namespace swarmloc::orchestrator {

const char* live_view_page() { return kLiveViewPageHtml; }

}  // namespace swarmloc::orchestrator
