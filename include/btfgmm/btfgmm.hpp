// btfgmm: a BTF compressed into a 9-D Gaussian mixture of product components.
// The umbrella header; see each header for its part.
#pragma once

#include "btfgmm/btf.hpp"
#include "btfgmm/checkpoint.hpp"
#include "btfgmm/dataset.hpp"
#include "btfgmm/directions.hpp"
#include "btfgmm/error.hpp"
#include "btfgmm/generate.hpp"
#include "btfgmm/image.hpp"
