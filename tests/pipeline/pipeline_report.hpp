// Looking up a stage of a pipeline run's report by its name, for the pipeline tests.
#pragma once

#include <stdexcept>
#include <string>

#include "kestrel/pipeline/pipeline.hpp"

namespace kestrel::test {

/// The stage called `name` ("source", "depth", "tracker", "fusion", "controller").
inline const pipeline::StageStats& stage(const pipeline::PipelineReport& r,
                                         const std::string& name) {
  for (const auto& s : r.stages) {
    if (s.name == name) return s;
  }
  throw std::runtime_error("no stage " + name);
}

}  // namespace kestrel::test
