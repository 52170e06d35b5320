// Opens any frame source from its URI: the one place that knows every scheme.
#pragma once

#include <memory>
#include <string>

#include "io/frame_source.h"

namespace ef {

// Schemes: synthetic:[ROOM|random][?seed=N&trajectory=loop|robot&frames=N], tum:DIR, 7scenes:DIR,
// klg:FILE[?size=WxH]. Unknown schemes and unknown query keys are errors that name them.
Result<std::unique_ptr<FrameSource>> open_source(const std::string& uri);

// "synthetic:, synthetic:ROOM, tum:DIR, ..." for help texts.
const char* source_uri_help();

}  // namespace ef
