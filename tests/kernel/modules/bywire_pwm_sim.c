// SPDX-License-Identifier: GPL-2.0
/*
 * bywire_pwm_sim: a PWM chip with no hardware behind it, for the kernel tier (tests/kernel).
 *
 * The kernel has no PWM simulator; this one registers a platform device "bywire-pwm-sim.0" with
 * `npwm` channels behind the real PWM core, so /sys/class/pwm/pwmchipN behaves as on a board:
 * export, then period, duty_cycle and enable checked by the core (a fresh channel has period 0
 * and refuses a duty cycle until it has one, as pwm-bcm2835 in 6.1, which has no get_state).
 * What the chip was last told, per channel, is read back from the device's `applied`
 * attribute: "<channel> <period_ns> <duty_ns> <enabled>" a line.
 */
#include <linux/module.h>
#include <linux/platform_device.h>
#include <linux/pwm.h>
#include <linux/slab.h>

#define NPWM_MAX 4
static unsigned int npwm = 2;
module_param(npwm, uint, 0444);
MODULE_PARM_DESC(npwm, "channels (1..4)");

struct sim_pwm {
	struct pwm_chip chip;
	struct pwm_state applied[NPWM_MAX];
};

static struct platform_device *sim_device;
static struct sim_pwm *sim;

static int sim_apply(struct pwm_chip *chip, struct pwm_device *pwm,
		     const struct pwm_state *state)
{
	sim->applied[pwm->hwpwm] = *state;
	return 0;
}

static const struct pwm_ops sim_ops = {
	.apply = sim_apply,
	.owner = THIS_MODULE,
};

static ssize_t applied_show(struct device *dev, struct device_attribute *attr, char *buf)
{
	ssize_t len = 0;
	unsigned int i;

	for (i = 0; i < npwm; i++)
		len += sysfs_emit_at(buf, len, "%u %llu %llu %d\n", i, sim->applied[i].period,
				     sim->applied[i].duty_cycle, sim->applied[i].enabled);
	return len;
}
static DEVICE_ATTR_RO(applied);

static int __init sim_init(void)
{
	int ret;

	if (npwm < 1 || npwm > NPWM_MAX)
		return -EINVAL;
	sim_device = platform_device_register_simple("bywire-pwm-sim", 0, NULL, 0);
	if (IS_ERR(sim_device))
		return PTR_ERR(sim_device);
	sim = kzalloc(sizeof(*sim), GFP_KERNEL);
	ret = sim ? 0 : -ENOMEM;
	if (!ret)
		ret = device_create_file(&sim_device->dev, &dev_attr_applied);
	if (!ret) {
		sim->chip.dev = &sim_device->dev;
		sim->chip.ops = &sim_ops;
		sim->chip.npwm = npwm;
		ret = pwmchip_add(&sim->chip);
		if (ret)
			device_remove_file(&sim_device->dev, &dev_attr_applied);
	}
	if (ret) {
		kfree(sim);
		platform_device_unregister(sim_device);
	}
	return ret;
}

static void __exit sim_exit(void)
{
	pwmchip_remove(&sim->chip);
	device_remove_file(&sim_device->dev, &dev_attr_applied);
	platform_device_unregister(sim_device);
	kfree(sim);
}

module_init(sim_init);
module_exit(sim_exit);
MODULE_DESCRIPTION("PWM chip simulator for bywire's kernel tier");
MODULE_LICENSE("GPL");
