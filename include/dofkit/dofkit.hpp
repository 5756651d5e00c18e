// dofkit — umbrella header.
#pragma once
#include "dofkit/ao.hpp"
#include "dofkit/coc.hpp"
#include "dofkit/error.hpp"
#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"
#include "dofkit/render.hpp"
