// The renderers' factories (one file each) and what they share.
#pragma once

#include <memory>

#include "renderers/renderer_base.hpp"

namespace tally::renderers {

std::unique_ptr<Renderer> makeForward(bool prepass);
std::unique_ptr<Renderer> makeDeferred();
std::unique_ptr<Renderer> makeVisbuffer();
std::unique_ptr<Renderer> makeLeanVisbuffer();
std::unique_ptr<Renderer> makeVolumeFog();  // workloads.cpp
std::unique_ptr<Renderer> makeRaytrace();   // workloads.cpp

}  // namespace tally::renderers
