#pragma once
// For tests that run the learned crack detector: skip (with where the model should be) when the
// committed model file is absent, as in a checkout without it.

#include "stages/damage/cracks/crack_net.h"

#include <gtest/gtest.h>

#include <filesystem>

#define RS_REQUIRE_CRACK_MODEL()                                                             \
  do {                                                                                       \
    if (!std::filesystem::exists(::rs::DefaultCrackModelPath()))                             \
      GTEST_SKIP() << "no learned crack model at " << ::rs::DefaultCrackModelPath().string() \
                   << " (stages/damage/cracks/model/train_crack_net.py writes it)";          \
  } while (0)
