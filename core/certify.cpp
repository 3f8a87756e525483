#include "core/certify.h"
